//! Mesh files and bitmap textures decoded in parallel ahead of the conversion, which
//! stays sequential (in file order, with its notes and first error as before): the
//! staircase of mitransient's examples (774 OBJ files, 10 JPEGs) spent most of its
//! load decoding them one after the other on one thread.
//!
//! What is decoded ahead is exactly what the conversion would read: the same file
//! (resolved as [`super::xml::resolve_in`] does) with the same options, and the
//! conversion takes a result only where its own path and options match; otherwise it
//! reads the file itself. A file's error is kept with its object and reported only if
//! the conversion reaches that object, so a texture no shape uses still costs nothing
//! but its decoding. Meshes are decoded [`SHAPES_AHEAD`] shapes at a time, so at most
//! that many decoded meshes wait beside the scene being built.

use super::meshes::{self, Mesh};
use super::xml::{Object, Parsed, Value, resolve_in};
use super::{SceneError, Texture};
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Top-level shapes whose files are decoded together, in parallel.
pub(super) const SHAPES_AHEAD: usize = 64;

/// A file to decode: which object asked for it, and how.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Job {
    /// An `obj` shape's file, `flip_tex_coords`.
    Obj(PathBuf, bool),
    /// A `ply` shape's file, `flip_tex_coords`.
    Ply(PathBuf, bool),
    /// A `bitmap` texture's file, `raw`.
    Bitmap(PathBuf, bool),
}

impl Job {
    /// The file.
    pub(super) fn path(&self) -> &Path {
        match self {
            Job::Obj(p, _) | Job::Ply(p, _) | Job::Bitmap(p, _) => p,
        }
    }
}

/// A decoded file.
enum Decoded {
    Mesh(Result<Mesh, SceneError>),
    Texture(Result<Texture, SceneError>),
}

/// Results of files decoded ahead, by object index.
#[derive(Default)]
pub(super) struct Prefetched {
    done: HashMap<usize, (Job, Decoded)>,
    /// Objects already handed to a batch (decoded, or found not to be decodable ahead).
    seen: std::collections::HashSet<usize>,
}

/// A property's value, read without marking it as used (the conversion reads it again
/// and marks it).
fn peek<'o>(o: &'o Object, name: &str) -> Option<&'o Value> {
    o.props.iter().find(|p| p.name == name).map(|p| &p.value)
}

/// A boolean property without marking it; `None` when it is not a boolean.
fn peek_bool(o: &Object, name: &str, default: bool) -> Option<bool> {
    match peek(o, name) {
        None => Some(default),
        Some(Value::Boolean(b)) => Some(*b),
        Some(_) => None,
    }
}

/// The file `o` names by its `filename`, resolved as the conversion resolves it (`file`:
/// the scene's main file).
pub(super) fn file_of(o: &Object, file: &str) -> Option<PathBuf> {
    let p = o.props.iter().find(|p| p.name == "filename")?;
    let Value::String(name) = &p.value else {
        return None;
    };
    let dir = Path::new(&*p.loc.file).parent().unwrap_or(Path::new(""));
    let main = Path::new(file).parent().unwrap_or(Path::new(""));
    Some(resolve_in(dir, &[main.to_path_buf()], name))
}

/// What object `o` would have decoded, if it is a file shape or a bitmap texture whose
/// options read cleanly (anything else is left to the conversion, which reports it).
fn job_of(o: &Object, file: &str) -> Option<Job> {
    match (o.tag, o.plugin.as_str()) {
        ("shape", "obj") => Some(Job::Obj(
            file_of(o, file)?,
            peek_bool(o, "flip_tex_coords", true)?,
        )),
        ("shape", "ply") => Some(Job::Ply(
            file_of(o, file)?,
            peek_bool(o, "flip_tex_coords", false)?,
        )),
        ("texture", "bitmap") => Some(Job::Bitmap(file_of(o, file)?, peek_bool(o, "raw", false)?)),
        _ => None,
    }
}

/// How the conversion names object `o` in its messages.
pub(super) fn what(o: &Object) -> String {
    format!("{} at {}", o.describe(), o.loc)
}

impl Prefetched {
    /// Decode, in parallel on the current rayon pool, the files of `objects` (indices
    /// into `parsed`) not handed to a batch before.
    pub(super) fn decode(&mut self, parsed: &Parsed, file: &str, objects: &[usize]) {
        let jobs: Vec<(usize, Job, String)> = objects
            .iter()
            .filter(|&&k| self.seen.insert(k))
            .filter_map(|&k| {
                let o = parsed.objects.get(k)?;
                Some((k, job_of(o, file)?, what(o)))
            })
            .collect();
        let decoded: Vec<(usize, Job, Decoded)> = jobs
            .into_par_iter()
            .map(|(k, job, what)| {
                let d = match &job {
                    Job::Obj(path, flip) => Decoded::Mesh(meshes::read_obj(path, &what, *flip)),
                    Job::Ply(path, flip) => Decoded::Mesh(meshes::read_ply(path, &what, *flip)),
                    Job::Bitmap(path, raw) => {
                        Decoded::Texture(super::bitmap::decode_bitmap(path, &what, *raw))
                    }
                };
                (k, job, d)
            })
            .collect();
        for (k, job, d) in decoded {
            self.done.insert(k, (job, d));
        }
    }

    /// The mesh of shape `k` decoded ahead as `job` asks, if it was.
    pub(super) fn take_mesh(&mut self, k: usize, job: &Job) -> Option<Result<Mesh, SceneError>> {
        match self.done.remove(&k) {
            Some((j, Decoded::Mesh(m))) if &j == job => Some(m),
            _ => None,
        }
    }

    /// The texture of texture object `k` decoded ahead as `job` asks, if it was.
    pub(super) fn take_texture(
        &mut self,
        k: usize,
        job: &Job,
    ) -> Option<Result<Texture, SceneError>> {
        match self.done.remove(&k) {
            Some((j, Decoded::Texture(t))) if &j == job => Some(t),
            _ => None,
        }
    }
}
