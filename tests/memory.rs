//! A film that outgrows its memory budget (issue 30): a request whose first pass cannot
//! fit is refused up front with the size foreseen; a film that grows past `--max-memory`
//! stops at its last whole pass, writes what it has (the same cube a render of that many
//! samples writes, bit for bit) and exits with status 3; the window's worker pauses with
//! the same message instead.

mod common;

use common::cli::{json, stderr, tempdir, tprf};
use std::time::{Duration, Instant};

/// The film: cornell at 32 x 32 pixels and 1024 bins, whose store grows with every pass
/// (its dense cube is 32 x 32 x 1024 x 16 B = 16 MiB of halves), asked for far more
/// samples than the budget lets it take.
/// Two threads: the budget counts a pass's scratch per thread, so the pass it stops at
/// is the same on any machine.
const FILM: [&str; 10] = [
    "--width",
    "32",
    "--height",
    "32",
    "--bins",
    "1024",
    "--seed",
    "7",
    "--threads",
    "2",
];
const SPP_ASKED: u64 = 4096;
/// The budget: the film's first passes fit (its fixed part is about 100 KiB), the
/// store's growth toward the dense 16 MiB does not. (It stops after an even number of
/// passes, where a render asked for the spp it reached makes the same passes.)
const MAX_MEMORY: &str = "4MiB";
const MAX_MEMORY_BYTES: u64 = 4 << 20;

/// Samples per pixel after `passes` passes of the doubling schedule far from its
/// target: passes go in pairs of 1, 2, 4, ... samples per pixel.
fn doubling_spp_after(passes: u64) -> u64 {
    (0..passes).map(|p| 1u64 << (p / 2)).sum()
}

/// The CLI: exit status 3, the message on stderr naming --max-memory, tprf.json's
/// `stopped` note, fewer samples than asked, the film's store within the budget, and a
/// cube equal bit for bit to a render asked for the samples it stopped at (whole
/// passes: the same passes, the same seed, no budget).
#[test]
fn a_film_that_outgrows_max_memory_stops_at_its_last_whole_pass() {
    let dir = tempdir("stop");
    let out = dir.join("stopped");
    let spp = SPP_ASKED.to_string();
    let mut args = vec!["render", "builtin:cornell", "--out", out.to_str().unwrap()];
    args.extend(FILM);
    args.extend(["--spp", &spp, "--uniform", "--max-memory", MAX_MEMORY]);
    let o = tprf(&args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("stopped: stopped at"), "{err}");
    assert!(err.contains("--max-memory"), "{err}");
    let meta = json(&out.join("tprf.json"));
    let stopped = &meta["stopped"];
    assert_eq!(stopped["reason"], "memory", "{meta}");
    assert_eq!(stopped["limited_by"], "max_memory", "{meta}");
    assert_eq!(stopped["limit_bytes"], MAX_MEMORY_BYTES, "{meta}");
    assert_eq!(stopped["spp_target"], SPP_ASKED, "{meta}");
    let got_spp = meta["spp"].as_u64().unwrap();
    let passes = meta["passes"].as_u64().unwrap();
    assert!((1..SPP_ASKED).contains(&got_spp), "{meta}");
    // Whole passes: the spp of the passes made, each whole.
    assert_eq!(got_spp, doubling_spp_after(passes), "{meta}");
    assert!(
        passes.is_multiple_of(2),
        "tune MAX_MEMORY: stopped after {passes} passes"
    );
    let store_bytes = meta["store"]["bytes"].as_u64().unwrap();
    assert!(
        store_bytes <= MAX_MEMORY_BYTES,
        "{store_bytes} > {MAX_MEMORY_BYTES}"
    );
    // It stopped because the store grew: a pass more would have gone over, so the
    // store already holds a fair part of the budget.
    assert!(store_bytes > MAX_MEMORY_BYTES / 8, "{store_bytes}");

    // The same request asked for the samples it stopped at, without a budget.
    let whole = dir.join("whole");
    let got = got_spp.to_string();
    let mut args = vec![
        "render",
        "builtin:cornell",
        "--out",
        whole.to_str().unwrap(),
    ];
    args.extend(FILM);
    args.extend(["--spp", &got, "--uniform"]);
    let o = tprf(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let a = std::fs::read(out.join("tprf.npy")).unwrap();
    let b = std::fs::read(whole.join("tprf.npy")).unwrap();
    assert!(a.starts_with(b"\x93NUMPY"), "a valid .npy");
    assert!(
        a == b,
        "the stopped cube is the render of its {got_spp} spp"
    );
    assert!(json(&whole.join("tprf.json")).get("stopped").is_none());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A budget the first pass cannot fit: refused before any pass, naming --max-memory and
/// the size foreseen, nothing written.
#[test]
fn a_first_pass_that_cannot_fit_is_refused_up_front() {
    let dir = tempdir("refuse");
    let out = dir.join("never");
    let mut args = vec!["render", "builtin:cornell", "--out", out.to_str().unwrap()];
    args.extend(FILM);
    args.extend(["--spp", "4", "--max-memory", "64KiB"]);
    let o = tprf(&args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("would need about"), "{err}");
    assert!(err.contains("--max-memory"), "{err}");
    assert!(!out.exists(), "nothing written");
    // A size that is not one names the option.
    let o = tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        out.to_str().unwrap(),
        "--max-memory",
        "2 furlongs",
    ]);
    assert!(stderr(&o).contains("--max-memory"), "{}", stderr(&o));
    assert!(!o.status.success());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The issue's own case: 4096 x 4096 pixels x 65536 bins under a 4 GB address-space
/// limit. A new film's rows are one shared empty row; counting it once per row (0.7 GiB
/// the process had not allocated) once let the first pass through, which then outgrew
/// the limit and the process aborted. Under `ulimit -v 4200000` (4.0 GiB) the pilot's
/// 3.4 GiB first pass must be refused up front (a fifth of the room is kept back), and
/// a limit this tight is one the old count let through (0.7 GiB more room).
#[cfg(target_os = "linux")]
#[test]
fn the_issues_4096_square_film_under_ulimit_v_is_refused_not_aborted() {
    let dir = tempdir("ulimit");
    let out = dir.join("never");
    let o = std::process::Command::new("sh")
        .args([
            "-c",
            "ulimit -v 4200000 && exec \"$0\" \"$@\"",
            env!("CARGO_BIN_EXE_tprf"),
            "render",
            "builtin:cornell",
            "--width",
            "4096",
            "--height",
            "4096",
            "--bins",
            "65536",
            "--spp",
            "64",
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .expect("run tprf under ulimit -v");
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "refused, not aborted: {err}");
    assert!(err.contains("would need about"), "{err}");
    assert!(!out.exists(), "nothing written");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The window's worker: its paced passes shrink to what fits, and when not even one
/// sample per pixel more fits the render pauses by itself with the message (never
/// fails, never aborts), its last snapshot holding the passes made; resumed, it tries
/// the pass again and pauses again, the budget still being short.
#[test]
fn the_worker_pauses_with_the_message_when_the_film_outgrows_its_budget() {
    use tprf_core::request::RenderRequest;
    use tprf_core::request::worker::{RenderWorker, WorkerState};
    let job = RenderRequest {
        width: 32,
        height: 32,
        bins: 1024,
        seed: 7,
        threads: Some(2),
        spp: Some(SPP_ASKED),
        uniform: true,
        max_memory_bytes: Some(MAX_MEMORY_BYTES),
        ..RenderRequest::new("builtin:cornell")
    };
    let w = RenderWorker::spawn(job, || {});
    let paused_for_memory = |w: &RenderWorker| {
        let start = Instant::now();
        loop {
            let s = w.status().unwrap();
            if s.state == WorkerState::Paused && s.memory_stop.is_some() {
                return s;
            }
            assert!(
                !w.is_finished(),
                "the worker ended instead of pausing: {:?}",
                s.state
            );
            assert!(start.elapsed() < Duration::from_secs(120), "never paused");
            std::thread::sleep(Duration::from_millis(20));
        }
    };
    let s = paused_for_memory(&w);
    let message = s.memory_stop.clone().unwrap();
    assert!(message.contains("max_memory"), "{message}");

    assert!(w.is_paused());
    assert!(s.store.bytes <= MAX_MEMORY_BYTES);
    let snap = w.latest().expect("the passes made are shown");
    assert_eq!(s.spp, snap.spp, "the status tells the film shown");
    // Paced passes are made as large as fit: it paused when not even one sample per
    // pixel more would fit, the store having grown into the budget.
    assert!(s.store.bytes > MAX_MEMORY_BYTES / 8, "{}", s.store.bytes);
    assert!(snap.spp >= 1 && snap.spp < SPP_ASKED, "{}", snap.spp);
    // Resumed: the same pass still does not fit.
    w.set_paused(false);
    std::thread::sleep(Duration::from_millis(200));
    paused_for_memory(&w);
    assert_eq!(
        w.latest().unwrap().spp,
        snap.spp,
        "no pass made over the budget"
    );
}

/// `tprf converge`: a setting whose film outgrows `--max-memory` ends at its last whole
/// pass, its checkpoints kept; the other settings run, the outputs are written, the
/// message names the setting and --max-memory, and the exit status is 3.
#[test]
fn converge_stops_a_setting_at_its_memory_budget_and_writes_the_rest() {
    let dir = tempdir("converge");
    let out = dir.join("converge");
    let o = tprf(&[
        "converge",
        "--reference",
        "analytic:furnace?rho=0.9",
        "--width",
        "32",
        "--height",
        "32",
        "--bins",
        "1024",
        "--threads",
        "2",
        // Far more than the budget lets a setting render: it ends on memory, not time.
        "--seconds",
        "600",
        "--max-memory",
        MAX_MEMORY,
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("default: stopped at"), "{err}");
    assert!(err.contains("--max-memory"), "{err}");
    let csv = std::fs::read_to_string(out.join("converge.csv")).unwrap();
    // The checkpoints made before the stop, at least the first pass's.
    assert!(csv.lines().skip(1).count() >= 1, "{csv}");
    assert!(out.join("converge.png").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
