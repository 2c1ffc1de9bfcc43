//! The command line: `tprf render`, `tprf merge`, `tprf batch`, `tprf oned`, `tprf view`, `tprf sensor`,
//! `tprf converge`, `tprf stability`, one file per command with its arguments. The
//! work is done by `tprf_core` (and the viewer); a command checks its arguments, calls
//! the library, reports progress, and its errors end here, printed once.

mod args;
pub mod batch;
pub mod converge;
mod interrupt;
pub mod merge;
pub mod nlos;
pub mod oned;
pub mod render;
pub mod sensor;
pub mod stability;
pub mod view;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

use batch::BatchArgs;
use converge::ConvergeArgs;
use merge::MergeArgs;
use oned::OnedArgs;
pub use oned::print_oned;
use render::RenderArgs;
use sensor::SensorArgs;
use stability::StabilityArgs;
use view::ViewArgs;

#[derive(Parser, Debug)]
#[command(
    name = "tprf",
    version,
    about = "Transient rendering: light in flight, TPRF cubes and time-of-flight sensors"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a transient cube (TPRF per pixel) of a scene.
    Render(RenderArgs),
    /// Merge the shard folders of `tprf render --shard K/N` into one cube folder: what
    /// one process rendering the whole image writes, bit for bit.
    Merge(MergeArgs),
    /// Render many jobs from a TOML manifest (jobs, and sweeps of scenes x settings,
    /// each optionally measured by sensor presets); complete outputs are skipped, so a
    /// re-run resumes.
    Batch(BatchArgs),
    /// The paper's 1-D world: print the exact impulse train (and the binned TPRF).
    Oned(OnedArgs),
    /// Measure a rendered cube with a time-of-flight sensor (light pulse, exposure
    /// gates, noise): the paper's TPRF sensor, without re-rendering.
    Sensor(SensorArgs),
    /// Error against run time: render progressively and compare with a reference at
    /// checkpoints evenly spaced in log time; writes converge.csv, converge.png and
    /// summary.md.
    Converge(ConvergeArgs),
    /// Stiff and extreme cases against independently derived answers or invariances;
    /// writes stability.md (case, setting, expected, got, relative error, NaN/Inf,
    /// verdict, kind).
    Stability(StabilityArgs),
    /// Non-line-of-sight imaging: `tprf nlos SCENE --out DIR` captures the transients of a
    /// grid of relay-wall points (tal's nlos.hdf5, H.npy, nlos.json).
    Nlos(nlos::NlosArgs),
    /// Open the viewer on a cube folder written by `tprf render` (no rendering), or on a
    /// scene to render (a .gltf/.glb or Mitsuba .xml path, or builtin:NAME). No argument:
    /// the last scene.
    View(ViewArgs),
}

/// Entry point of the `tprf` binary.
pub fn main() -> std::process::ExitCode {
    // `tprf render --help` shows the request's defaults (`args::with_request_defaults`).
    let matches = args::with_request_defaults(Cli::command()).get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    let result = match &cli.command {
        Some(Command::Render(a)) => render::run(a),
        Some(Command::Merge(a)) => merge::run(a),
        Some(Command::Batch(a)) => batch::run(a),
        Some(Command::Oned(a)) => oned::run(a),
        Some(Command::Converge(a)) => converge::run(a),
        Some(Command::Stability(a)) => stability::run(a),
        Some(Command::View(a)) => view::run(a),
        Some(Command::Sensor(a)) => sensor::run(a),
        Some(Command::Nlos(a)) => nlos::run(a),
        None => view::run(&ViewArgs { what: None }),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => match e.downcast_ref::<render::StoppedForMemory>() {
            // The output was written (the passes made); said apart from a failure.
            Some(stop) => {
                eprintln!("stopped: {stop}");
                std::process::ExitCode::from(render::StoppedForMemory::EXIT_STATUS)
            }
            None => {
                eprintln!("error: {}", message_chain(&e));
                std::process::ExitCode::FAILURE
            }
        },
    }
}

/// An error and its causes, "a: b: c", a cause its parent's message already quotes
/// left out (an I/O error some messages carry and also give as their source).
pub(crate) fn message_chain(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let more = cause.to_string();
        if text.is_empty() {
            text = more;
        } else if !text.ends_with(&more) {
            text.push_str(": ");
            text.push_str(&more);
        }
    }
    text
}
