//! Mitsuba 3's XML format read into a tree of objects and typed properties, as Mitsuba's
//! own parser (`src/core/parser.cpp`) reads it: `<default>` and `$name` substitution
//! (`\$` escapes a dollar), `<include>` (the included file's `<scene>` children merged
//! into the including element; relative to the including file's folder, then to the
//! `<path>` folders), `<ref id>` and `<alias>`, `<path>`, `<transform>` blocks (see
//! [`super::transform`]), and files of version < 2 upgraded (camelCase property names to
//! snake_case, a `diffuse` BSDF's `diffuse_reflectance` to `reflectance`, `uoffset`,
//! `voffset`, `uscale`, `vscale` to a `to_uv` transform).
//!
//! Hostile input: the XML crate (roxmltree) refuses a DTD (no entity expansion) and
//! parses without recursion; this reader refuses more than [`MAX_NODES`] XML nodes,
//! elements nested deeper than [`MAX_DEPTH`], includes deeper than
//! [`MAX_INCLUDE_DEPTH`] or in a cycle, a `<ref>` cycle, numbers that are not finite
//! or do not fit, and reads files only if they are regular files that fit in memory.
//! Every error names the file and line.

use super::transform;
use crate::scene::SceneError;
use glam::DMat4;
use std::cell::Cell;
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Most XML nodes (elements, text, comments) one file may have: a scene description is
/// small; meshes live in their own files.
pub(super) const MAX_NODES: u32 = 4_000_000;
/// Deepest nesting of elements (Mitsuba scenes nest a few levels: shape, BSDF, texture).
pub(super) const MAX_DEPTH: usize = 64;
/// Deepest chain of `<include>`s (Mitsuba's own limit).
pub(super) const MAX_INCLUDE_DEPTH: usize = 15;

/// Where an element is: its file and line (1-based).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub(super) struct Loc {
    pub file: Rc<str>,
    pub line: u32,
}

impl fmt::Display for Loc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.file, self.line)
    }
}

/// A [`SceneError::Mitsuba`] at `loc`.
pub(super) fn err(loc: &Loc, message: impl Into<String>) -> SceneError {
    SceneError::Mitsuba {
        location: loc.to_string(),
        message: message.into(),
    }
}

/// A spectrum as the file gives it.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Spectrum {
    /// One value at every wavelength.
    Uniform(f64),
    /// `wavelength:value` pairs, or a file of them: read only to be refused by name.
    Sampled,
    File(String),
}

/// A property's value.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Value {
    Float(f64),
    Integer(i64),
    Boolean(bool),
    String(String),
    Rgb([f64; 3]),
    Spectrum(Spectrum),
    /// `<point>` and `<vector>`.
    Vector([f64; 3]),
    Transform(DMat4),
    /// A nested or referenced object (index into [`Parsed::objects`]).
    Object(usize),
}

impl Value {
    /// The element that gives a value of this kind, for messages: `<float>`.
    pub(super) fn tag(&self) -> &'static str {
        match self {
            Value::Float(_) => "float",
            Value::Integer(_) => "integer",
            Value::Boolean(_) => "boolean",
            Value::String(_) => "string",
            Value::Rgb(_) => "rgb",
            Value::Spectrum(_) => "spectrum",
            Value::Vector(_) => "point",
            Value::Transform(_) => "transform",
            Value::Object(_) => "object",
        }
    }
}

/// A named property of an object; `used` is set when a converter reads it, so what
/// no converter read can be noted.
#[derive(Debug)]
pub(super) struct Prop {
    pub name: String,
    pub value: Value,
    pub loc: Loc,
    pub used: Cell<bool>,
}

/// An object element: `<shape type="obj" id="floor">` and its properties (nested
/// objects among them, named or `_arg_N`).
#[derive(Debug)]
pub(super) struct Object {
    /// The element: `scene`, `shape`, `bsdf`, `texture`, `emitter`, `sensor`, `film`,
    /// `sampler`, `rfilter`, `integrator`, `medium`, `phase`, `volume`.
    pub tag: &'static str,
    /// Its `type` (`scene` for the root).
    pub plugin: String,
    pub id: Option<String>,
    pub loc: Loc,
    pub props: Vec<Prop>,
    /// Set when a converter reads the object (its unread properties are then noted).
    pub visited: Cell<bool>,
}

/// A colour-valued property: a constant (linear RGB) or a texture object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Color {
    Rgb([f64; 3]),
    Texture(usize),
}

impl Object {
    /// The property `name`, marked as read.
    pub(super) fn prop(&self, name: &str) -> Option<&Prop> {
        let p = self.props.iter().find(|p| p.name == name)?;
        p.used.set(true);
        Some(p)
    }

    fn wrong_type(&self, p: &Prop, want: &str) -> SceneError {
        err(
            &p.loc,
            format!(
                "<{} name=\"{}\"> of {}: expected {want}",
                p.value.tag(),
                p.name,
                self.describe()
            ),
        )
    }

    /// A number (`<float>` or `<integer>`), or `default`.
    pub(super) fn float(&self, name: &str, default: f64) -> Result<f64, SceneError> {
        match self.prop(name) {
            None => Ok(default),
            Some(p) => match p.value {
                Value::Float(v) => Ok(v),
                Value::Integer(v) => Ok(v as f64),
                _ => Err(self.wrong_type(p, "a <float>")),
            },
        }
    }

    /// An `<integer>`, or `default`; with where it was given (`None` for the default).
    pub(super) fn integer(
        &self,
        name: &str,
        default: i64,
    ) -> Result<(i64, Option<&Prop>), SceneError> {
        match self.prop(name) {
            None => Ok((default, None)),
            Some(p) => match p.value {
                Value::Integer(v) => Ok((v, Some(p))),
                _ => Err(self.wrong_type(p, "an <integer>")),
            },
        }
    }

    pub(super) fn boolean(&self, name: &str, default: bool) -> Result<bool, SceneError> {
        match self.prop(name) {
            None => Ok(default),
            Some(p) => match p.value {
                Value::Boolean(v) => Ok(v),
                _ => Err(self.wrong_type(p, "a <boolean>")),
            },
        }
    }

    pub(super) fn string(&self, name: &str) -> Result<Option<&str>, SceneError> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                Value::String(v) => Ok(Some(v.as_str())),
                _ => Err(self.wrong_type(p, "a <string>")),
            },
        }
    }

    /// A `<point>` or `<vector>`.
    pub(super) fn vector(&self, name: &str) -> Result<Option<[f64; 3]>, SceneError> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match p.value {
                Value::Vector(v) => Ok(Some(v)),
                _ => Err(self.wrong_type(p, "a <point> or <vector>")),
            },
        }
    }

    /// A `<transform>`, or identity.
    pub(super) fn transform(&self, name: &str) -> Result<DMat4, SceneError> {
        match self.prop(name) {
            None => Ok(DMat4::IDENTITY),
            Some(p) => match p.value {
                Value::Transform(m) => Ok(m),
                _ => Err(self.wrong_type(p, "a <transform>")),
            },
        }
    }

    /// A colour or spectrum: `<rgb>`, `<float>`, a uniform `<spectrum>`, or a texture
    /// object; `default` when absent. Spectra by wavelength or from a file are refused
    /// (tprf's colours are RGB).
    pub(super) fn color(
        &self,
        name: &str,
        default: Option<[f64; 3]>,
    ) -> Result<Option<Color>, SceneError> {
        let Some(p) = self.prop(name) else {
            return Ok(default.map(Color::Rgb));
        };
        match &p.value {
            Value::Rgb(c) => Ok(Some(Color::Rgb(*c))),
            Value::Float(v) => Ok(Some(Color::Rgb([*v; 3]))),
            Value::Integer(v) => Ok(Some(Color::Rgb([*v as f64; 3]))),
            Value::Spectrum(Spectrum::Uniform(v)) => Ok(Some(Color::Rgb([*v; 3]))),
            Value::Spectrum(_) => Err(err(
                &p.loc,
                format!(
                    "<spectrum name=\"{}\"> given by wavelength or from a file is not supported: \
                     tprf's colours are RGB (give <rgb> or a single value)",
                    p.name
                ),
            )),
            Value::Object(k) => Ok(Some(Color::Texture(*k))),
            _ => Err(self.wrong_type(p, "a colour (<rgb>, <spectrum>, <float> or <texture>)")),
        }
    }

    /// The nested objects (named and unnamed), in file order: (property, object index).
    pub(super) fn children(&self) -> impl Iterator<Item = (&Prop, usize)> {
        self.props.iter().filter_map(|p| match p.value {
            Value::Object(k) => Some((p, k)),
            _ => None,
        })
    }

    /// `<bsdf type="diffuse">` (with its id, when it has one), for messages.
    pub(super) fn describe(&self) -> String {
        match &self.id {
            Some(id) => format!("<{} type=\"{}\" id=\"{id}\">", self.tag, self.plugin),
            None => format!("<{} type=\"{}\">", self.tag, self.plugin),
        }
    }
}

/// The parsed scene: every object, the root first.
#[derive(Debug)]
pub(super) struct Parsed {
    pub objects: Vec<Object>,
}

/// A `<ref>` waiting for every id to be known: the object and property it fills.
struct PendingRef {
    object: usize,
    prop: usize,
    id: String,
}

/// Object elements and the tag names they have.
const OBJECT_TAGS: [&str; 13] = [
    "scene",
    "shape",
    "bsdf",
    "texture",
    "emitter",
    "sensor",
    "film",
    "sampler",
    "rfilter",
    "integrator",
    "medium",
    "phase",
    "volume",
];

struct Reader {
    objects: Vec<Object>,
    /// `$name` values: `<default>`s in document order (the first one of a name wins,
    /// as in Mitsuba).
    params: Vec<(String, String)>,
    ids: HashMap<String, (usize, Loc)>,
    refs: Vec<PendingRef>,
    /// `<path>` folders, newest first.
    search: Vec<PathBuf>,
    /// Files being read, outermost first (include cycles).
    stack: Vec<PathBuf>,
}

/// Read `path` and everything it includes.
pub(super) fn parse(path: &Path) -> Result<Parsed, SceneError> {
    let mut r = Reader {
        objects: Vec::new(),
        params: Vec::new(),
        ids: HashMap::new(),
        refs: Vec::new(),
        search: Vec::new(),
        stack: Vec::new(),
    };
    r.file(path, None, None)?;
    for pending in std::mem::take(&mut r.refs) {
        let (target, _) = match r.ids.get(&pending.id) {
            Some(t) => t.clone(),
            None => {
                let prop = &r.objects[pending.object].props[pending.prop];
                return Err(err(
                    &prop.loc,
                    format!("<ref id=\"{}\">: no object has this id", pending.id),
                ));
            }
        };
        r.objects[pending.object].props[pending.prop].value = Value::Object(target);
    }
    let parsed = Parsed { objects: r.objects };
    parsed.check_cycles()?;
    Ok(parsed)
}

impl Parsed {
    /// Refuse an object that contains itself through references (a `<ref>` to an
    /// enclosing object): depth-first search with the path on a stack.
    fn check_cycles(&self) -> Result<(), SceneError> {
        // 0 = not seen, 1 = on the path, 2 = done.
        let mut state = vec![0u8; self.objects.len()];
        for start in 0..self.objects.len() {
            if state[start] != 0 {
                continue;
            }
            let mut stack: Vec<(usize, usize)> = vec![(start, 0)];
            state[start] = 1;
            while let Some((o, next)) = stack.last_mut() {
                let obj = &self.objects[*o];
                let child =
                    obj.props[*next..]
                        .iter()
                        .enumerate()
                        .find_map(|(k, p)| match p.value {
                            Value::Object(c) => Some((k, c)),
                            _ => None,
                        });
                match child {
                    None => {
                        state[*o] = 2;
                        stack.pop();
                    }
                    Some((k, c)) => {
                        *next += k + 1;
                        match state.get(c).copied() {
                            Some(0) => {
                                state[c] = 1;
                                stack.push((c, 0));
                            }
                            Some(1) => {
                                let inner = &self.objects[c];
                                return Err(err(
                                    &obj.loc,
                                    format!(
                                        "{} refers to {} ({}), which contains it: a reference cycle",
                                        obj.describe(),
                                        inner.describe(),
                                        inner.loc
                                    ),
                                ));
                            }
                            _ => {}
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

/// Where each line of a file starts, for the line of a byte offset in O(log lines).
/// (`roxmltree::Document::text_pos_at` counts the newlines from the file's start on
/// every call: asked for each element's line, that made loading quadratic in the
/// elements, 32 s for 20 000 shapes.)
pub(super) struct LineIndex {
    /// Byte offsets of the file's `\n`s, ascending.
    newlines: Vec<usize>,
}

impl LineIndex {
    pub(super) fn new(text: &str) -> Self {
        let newlines = text
            .bytes()
            .enumerate()
            .filter_map(|(i, b)| (b == b'\n').then_some(i))
            .collect();
        LineIndex { newlines }
    }

    /// The 1-based line of byte offset `pos`: one more than the newlines before it.
    pub(super) fn line_of(&self, pos: usize) -> u32 {
        let before = self.newlines.partition_point(|&nl| nl < pos);
        u32::try_from(before).map_or(u32::MAX, |n| n.saturating_add(1))
    }
}

/// `camelCase` as `camel_case` (Mitsuba's rule for files of version < 2).
fn camel_to_snake(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if i > 0 && chars[i - 1].is_ascii_lowercase() && c.is_ascii_uppercase() {
            out.push('_');
            out.push(c.to_ascii_lowercase());
            while i + 1 < chars.len() && chars[i + 1].is_ascii_uppercase() {
                i += 1;
                out.push(chars[i].to_ascii_lowercase());
            }
        } else {
            out.push(c);
        }
        i += 1;
    }
    out
}

/// A version attribute `X.Y.Z` (or `X.Y`, `X`): its major number.
fn major_version(v: &str) -> Option<u32> {
    let mut parts = v.trim().split('.');
    let major = parts.next()?.parse::<u32>().ok()?;
    for p in parts {
        p.parse::<u32>().ok()?;
    }
    Some(major)
}

/// Parse a finite number, or say what is wrong with it.
pub(super) fn parse_f64(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("\"{s}\" is not a number"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("\"{s}\" is not a finite number"))
    }
}

/// Numbers separated by commas and/or white space.
pub(super) fn parse_list(s: &str) -> Result<Vec<f64>, String> {
    s.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(parse_f64)
        .collect()
}

/// Three numbers (`"1, 2, 3"`).
pub(super) fn parse_vec3(s: &str) -> Result<[f64; 3], String> {
    match parse_list(s)?.as_slice() {
        &[x, y, z] => Ok([x, y, z]),
        v => Err(format!("\"{s}\": expected 3 numbers, got {}", v.len())),
    }
}

impl Reader {
    /// Read one file: its root becomes a new object (the scene), or, for an include,
    /// its children go into `parent` (`name`: the include's name for a non-scene root).
    fn file(
        &mut self,
        path: &Path,
        parent: Option<usize>,
        include: Option<(&Loc, Option<&str>)>,
    ) -> Result<(), SceneError> {
        let display = path.display().to_string();
        let canonical = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        if let Some((loc, _)) = include {
            if self.stack.contains(&canonical) {
                let chain: Vec<String> = self
                    .stack
                    .iter()
                    .chain(std::iter::once(&canonical))
                    .map(|p| p.display().to_string())
                    .collect();
                return Err(err(
                    loc,
                    format!("<include> cycle: {}", chain.join(" includes ")),
                ));
            }
            if self.stack.len() > MAX_INCLUDE_DEPTH {
                return Err(err(
                    loc,
                    format!("<include>s nested deeper than {MAX_INCLUDE_DEPTH} files"),
                ));
            }
        }
        let bytes = crate::budget::read_file(path, "the scene file").map_err(|e| match e {
            crate::budget::BudgetError::Io { source, .. } => SceneError::Io {
                path: match include {
                    Some((loc, _)) => format!("{display} (included at {loc})"),
                    None => display.clone(),
                },
                source,
            },
            e => SceneError::Budget(e),
        })?;
        let file_loc = Loc {
            file: Rc::from(display.as_str()),
            line: 0,
        };
        let text = String::from_utf8(bytes).map_err(|e| SceneError::Mitsuba {
            location: display.clone(),
            message: format!("not UTF-8 text ({e})"),
        })?;
        let options = roxmltree::ParsingOptions {
            allow_dtd: false,
            nodes_limit: MAX_NODES,
            ..Default::default()
        };
        let doc = roxmltree::Document::parse_with_options(&text, options).map_err(|e| {
            let pos = e.pos();
            SceneError::Mitsuba {
                location: format!("{display}:{}:{}", pos.row, pos.col),
                message: match e {
                    roxmltree::Error::NodesLimitReached => {
                        format!("more than {MAX_NODES} XML nodes: not a scene description")
                    }
                    e => format!("not well-formed XML: {e}"),
                },
            }
        })?;
        let lines = LineIndex::new(&text);
        let root = doc.root_element();
        let loc = Loc {
            line: lines.line_of(root.range().start),
            ..file_loc
        };
        let Some(version) = root.attribute("version") else {
            return Err(err(
                &loc,
                format!(
                    "<{}> has no version attribute: a Mitsuba scene starts with <scene version=\"3.0.0\">",
                    root.tag_name().name()
                ),
            ));
        };
        let version = self.substitute(version, &loc)?;
        let major = major_version(&version).ok_or_else(|| {
            err(
                &loc,
                format!("version=\"{version}\" is not a version number"),
            )
        })?;
        // Deepest nesting, before any recursion: depths in document order, where a
        // parent comes before its children.
        let mut depth = vec![0usize; doc.descendants().count() + 1];
        let mut deep = None;
        for n in doc.descendants() {
            let d = n.parent().map_or(0, |p| {
                depth.get(p.id().get() as usize).copied().unwrap_or(0) + 1
            });
            if let Some(slot) = depth.get_mut(n.id().get() as usize) {
                *slot = d;
            }
            if d > MAX_DEPTH {
                deep = Some(n);
                break;
            }
        }
        if let Some(deep) = deep {
            let l = Loc {
                line: lines.line_of(deep.range().start),
                ..loc.clone()
            };
            return Err(err(
                &l,
                format!("elements nested deeper than {MAX_DEPTH} levels"),
            ));
        }
        self.stack.push(canonical);
        let ctx = FileCtx {
            lines: &lines,
            file: loc.file.clone(),
            dir: path.parent().unwrap_or(Path::new("")).to_path_buf(),
            upgrade: major < 2,
        };
        let result = match (parent, root.tag_name().name()) {
            (Some(p), "scene") => root
                .children()
                .filter(|c| c.is_element())
                .try_for_each(|c| self.element(&ctx, c, p)),
            (Some(p), _) => {
                let name = include.and_then(|(_, n)| n);
                self.element_named(&ctx, root, p, name)
            }
            (None, "scene") => {
                let idx = self.new_object(&ctx, root, "scene", "scene".into())?;
                root.children()
                    .filter(|c| c.is_element())
                    .try_for_each(|c| self.element(&ctx, c, idx))
            }
            (None, other) => Err(err(
                &loc,
                format!(
                    "the root element is <{other}>: a Mitsuba scene file has <scene> at its root"
                ),
            )),
        };
        self.stack.pop();
        result
    }

    /// `$name` replaced by its `<default>` value (`\$` stands for `$`); an undefined
    /// name is an error.
    fn substitute(&self, value: &str, loc: &Loc) -> Result<String, SceneError> {
        if !value.contains('$') {
            return Ok(value.to_string());
        }
        let mut out = String::with_capacity(value.len());
        let mut rest = value;
        while let Some(pos) = rest.find('$') {
            let escaped = rest[..pos].ends_with('\\');
            if escaped {
                out.push_str(&rest[..pos - 1]);
                out.push('$');
                rest = &rest[pos + 1..];
                continue;
            }
            out.push_str(&rest[..pos]);
            let after = &rest[pos + 1..];
            let len = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            // The longest defined name that the text starts with (Mitsuba sorts its
            // parameters longest first).
            let best = self
                .params
                .iter()
                .filter(|(k, _)| after[..len].starts_with(k.as_str()) && !k.is_empty())
                .max_by_key(|(k, _)| k.len());
            match best {
                Some((k, v)) => {
                    out.push_str(v);
                    rest = &after[k.len()..];
                }
                None => {
                    return Err(err(
                        loc,
                        format!(
                            "${} is not defined: add <default name=\"{}\" value=\"...\"/> before it",
                            &after[..len],
                            &after[..len]
                        ),
                    ));
                }
            }
        }
        out.push_str(rest);
        Ok(out)
    }

    /// An attribute of `node` after `$` substitution.
    fn attr(
        &self,
        node: roxmltree::Node,
        name: &str,
        loc: &Loc,
    ) -> Result<Option<String>, SceneError> {
        node.attribute(name)
            .map(|v| self.substitute(v, loc))
            .transpose()
    }

    /// A required attribute.
    fn need(&self, node: roxmltree::Node, name: &str, loc: &Loc) -> Result<String, SceneError> {
        self.attr(node, name, loc)?.ok_or_else(|| {
            err(
                loc,
                format!(
                    "<{}> needs a {name}=\"...\" attribute",
                    node.tag_name().name()
                ),
            )
        })
    }

    fn new_object(
        &mut self,
        ctx: &FileCtx,
        node: roxmltree::Node,
        tag: &'static str,
        plugin: String,
    ) -> Result<usize, SceneError> {
        let loc = ctx.loc(node);
        let id = self.attr(node, "id", &loc)?;
        let idx = self.objects.len();
        if let Some(id) = &id {
            if let Some((_, first)) = self.ids.get(id) {
                return Err(err(
                    &loc,
                    format!("id \"{id}\" is used twice (first at {first})"),
                ));
            }
            self.ids.insert(id.clone(), (idx, loc.clone()));
        }
        self.objects.push(Object {
            tag,
            plugin,
            id,
            loc,
            props: Vec::new(),
            visited: Cell::new(false),
        });
        Ok(idx)
    }

    fn element(
        &mut self,
        ctx: &FileCtx,
        node: roxmltree::Node,
        parent: usize,
    ) -> Result<(), SceneError> {
        self.element_named(ctx, node, parent, None)
    }

    /// Add `node` (a child of object `parent`) to it: a property, a nested object, or
    /// one of the structural elements (`default`, `include`, `ref`, `alias`, `path`).
    fn element_named(
        &mut self,
        ctx: &FileCtx,
        node: roxmltree::Node,
        parent: usize,
        name_override: Option<&str>,
    ) -> Result<(), SceneError> {
        let loc = ctx.loc(node);
        let tag = node.tag_name().name();
        let name = match name_override {
            Some(n) => Some(n.to_string()),
            None => self.attr(node, "name", &loc)?,
        };
        let name = name.map(|n| if ctx.upgrade { camel_to_snake(&n) } else { n });
        let auto_name = |objects: &[Object]| format!("_arg_{}", objects[parent].props.len());
        let value = match tag {
            "default" => {
                let n = self.need(node, "name", &loc)?;
                let v = self.need(node, "value", &loc)?;
                if n.is_empty() {
                    return Err(err(&loc, "<default> needs a non-empty name"));
                }
                if !self.params.iter().any(|(k, _)| *k == n) {
                    self.params.push((n, v));
                }
                return Ok(());
            }
            "include" => {
                let file = self.need(node, "filename", &loc)?;
                let path = self.resolve(ctx, &file);
                return self.file(&path, Some(parent), Some((&loc, name.as_deref())));
            }
            "path" => {
                let v = self.need(node, "value", &loc)?;
                let p = ctx.dir.join(&v);
                if !p.is_dir() {
                    return Err(err(
                        &loc,
                        format!("<path value=\"{v}\">: no folder {}", p.display()),
                    ));
                }
                self.search.insert(0, p);
                return Ok(());
            }
            "alias" => {
                let id = self.need(node, "id", &loc)?;
                let as_ = self.need(node, "as", &loc)?;
                let target = self.ids.get(&id).cloned().ok_or_else(|| {
                    err(
                        &loc,
                        format!("<alias id=\"{id}\">: no object has this id (yet)"),
                    )
                })?;
                if self.ids.contains_key(&as_) {
                    return Err(err(&loc, format!("<alias as=\"{as_}\">: the id is taken")));
                }
                self.ids.insert(as_, target);
                return Ok(());
            }
            "ref" => {
                let id = self.need(node, "id", &loc)?;
                let prop_name = name.unwrap_or_else(|| auto_name(&self.objects));
                let prop = self.objects[parent].props.len();
                self.objects[parent].props.push(Prop {
                    name: prop_name,
                    value: Value::Integer(0),
                    loc,
                    used: Cell::new(false),
                });
                self.refs.push(PendingRef {
                    object: parent,
                    prop,
                    id,
                });
                return Ok(());
            }
            "float" => Value::Float(self.number(node, &loc)?),
            "integer" => {
                let v = self.need(node, "value", &loc)?;
                Value::Integer(v.trim().parse::<i64>().map_err(|e| {
                    let why = match e.kind() {
                        std::num::IntErrorKind::PosOverflow
                        | std::num::IntErrorKind::NegOverflow => "does not fit in 64 bits",
                        _ => "is not an integer",
                    };
                    err(&loc, format!("<integer value=\"{v}\">: {why}"))
                })?)
            }
            "boolean" => {
                let v = self.need(node, "value", &loc)?;
                Value::Boolean(match v.trim().to_ascii_lowercase().as_str() {
                    "true" => true,
                    "false" => false,
                    _ => {
                        return Err(err(
                            &loc,
                            format!("<boolean value=\"{v}\">: must be true or false"),
                        ));
                    }
                })
            }
            "string" => Value::String(self.need(node, "value", &loc)?),
            "rgb" | "color" => {
                let v = self.need(node, "value", &loc)?;
                let c = parse_list(&v).map_err(|m| err(&loc, format!("<rgb>: {m}")))?;
                Value::Rgb(match *c.as_slice() {
                    [x] => [x; 3],
                    [r, g, b] => [r, g, b],
                    _ => {
                        return Err(err(
                            &loc,
                            format!("<rgb value=\"{v}\">: needs 1 or 3 numbers"),
                        ));
                    }
                })
            }
            "spectrum" if node.attribute("type").is_some() => {
                return self.object(ctx, node, parent, "texture", name);
            }
            "spectrum" => {
                let value = self.attr(node, "value", &loc)?;
                let file = self.attr(node, "filename", &loc)?;
                Value::Spectrum(match (value, file) {
                    (Some(v), None) => {
                        if v.contains(':') {
                            // Check the pairs parse, for a clear error on garbage.
                            for pair in v.split(',') {
                                let (w, x) = pair.split_once(':').unwrap_or((pair, ""));
                                parse_f64(w)
                                    .and_then(|_| parse_f64(x))
                                    .map_err(|m| err(&loc, format!("<spectrum>: {m}")))?;
                            }
                            Spectrum::Sampled
                        } else {
                            Spectrum::Uniform(
                                parse_f64(&v).map_err(|m| err(&loc, format!("<spectrum>: {m}")))?,
                            )
                        }
                    }
                    (None, Some(f)) => Spectrum::File(f),
                    _ => {
                        return Err(err(
                            &loc,
                            "<spectrum> needs either value=\"...\" or filename=\"...\"",
                        ));
                    }
                })
            }
            "point" | "vector" => {
                let v = match self.attr(node, "value", &loc)? {
                    Some(v) => parse_vec3(&v).map_err(|m| err(&loc, format!("<{tag}>: {m}")))?,
                    None => {
                        let mut out = [0.0; 3];
                        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
                            if let Some(s) = self.attr(node, axis, &loc)? {
                                out[k] = parse_f64(&s)
                                    .map_err(|m| err(&loc, format!("<{tag}> {axis}: {m}")))?;
                            }
                        }
                        out
                    }
                };
                Value::Vector(v)
            }
            "transform" => {
                let mut m = DMat4::IDENTITY;
                for op in node.children().filter(|c| c.is_element()) {
                    let oloc = ctx.loc(op);
                    let attr = |n: &str| self.attr(op, n, &oloc);
                    m = transform::apply(op.tag_name().name(), &attr, &oloc)? * m;
                }
                Value::Transform(m)
            }
            t if OBJECT_TAGS.contains(&t) && t != "scene" => {
                let tag = OBJECT_TAGS
                    .iter()
                    .copied()
                    .find(|x| *x == t)
                    .unwrap_or("shape");
                return self.object(ctx, node, parent, tag, name);
            }
            "scene" => return Err(err(&loc, "<scene> inside a scene")),
            "translate" | "rotate" | "scale" | "lookat" | "matrix" => {
                return Err(err(
                    &loc,
                    format!("<{tag}> can only appear inside a <transform>"),
                ));
            }
            other => return Err(err(&loc, format!("<{other}> is not a Mitsuba 3 element"))),
        };
        if tag != "transform"
            && let Some(child) = node.children().find(|c| c.is_element())
        {
            return Err(err(
                &ctx.loc(child),
                format!(
                    "<{}> cannot be inside the property <{tag}>",
                    child.tag_name().name()
                ),
            ));
        }
        let Some(name) = name else {
            return Err(err(&loc, format!("<{tag}> needs a name=\"...\" attribute")));
        };
        let props = &mut self.objects[parent].props;
        if let Some(first) = props.iter().find(|p| p.name == name) {
            return Err(err(
                &loc,
                format!(
                    "property \"{name}\" is given twice (first at {})",
                    first.loc
                ),
            ));
        }
        props.push(Prop {
            name,
            value,
            loc,
            used: Cell::new(false),
        });
        Ok(())
    }

    /// A nested object: added as a property of `parent` (named, or `_arg_N`) and its
    /// children read into it.
    fn object(
        &mut self,
        ctx: &FileCtx,
        node: roxmltree::Node,
        parent: usize,
        tag: &'static str,
        name: Option<String>,
    ) -> Result<(), SceneError> {
        let loc = ctx.loc(node);
        let plugin = self.need(node, "type", &loc)?;
        let idx = self.new_object(ctx, node, tag, plugin)?;
        let prop_name =
            name.unwrap_or_else(|| format!("_arg_{}", self.objects[parent].props.len()));
        self.objects[parent].props.push(Prop {
            name: prop_name,
            value: Value::Object(idx),
            loc,
            used: Cell::new(false),
        });
        for child in node.children().filter(|c| c.is_element()) {
            self.element(ctx, child, idx)?;
        }
        if ctx.upgrade {
            upgrade_v1(&mut self.objects[idx]);
        }
        Ok(())
    }

    fn number(&self, node: roxmltree::Node, loc: &Loc) -> Result<f64, SceneError> {
        let v = self.need(node, "value", loc)?;
        parse_f64(&v).map_err(|m| err(loc, format!("<{}>: {m}", node.tag_name().name())))
    }

    /// A file named in `file` (included XML): relative to the file that names it, then
    /// to the `<path>` folders.
    fn resolve(&self, ctx: &FileCtx, file: &str) -> PathBuf {
        resolve_in(&ctx.dir, &self.search, file)
    }
}

/// A path as Mitsuba's file resolver finds it: absolute as given; relative, the first of
/// `dir/file` and `search[i]/file` that exists, else `dir/file` (for the error).
pub(super) fn resolve_in(dir: &Path, search: &[PathBuf], file: &str) -> PathBuf {
    let p = Path::new(file);
    if p.is_absolute() {
        return p.to_path_buf();
    }
    std::iter::once(dir)
        .chain(search.iter().map(PathBuf::as_path))
        .map(|d| d.join(p))
        .find(|c| c.exists())
        .unwrap_or_else(|| dir.join(p))
}

/// The upgrade Mitsuba applies to objects of files of version < 2, beyond the
/// camelCase names: `diffuse_reflectance` of a diffuse BSDF is `reflectance`, and
/// `uoffset`, `voffset`, `uscale`, `vscale` are a `to_uv` transform.
fn upgrade_v1(o: &mut Object) {
    if o.plugin == "diffuse" {
        for p in &mut o.props {
            if p.name == "diffuse_reflectance" {
                p.name = "reflectance".into();
            }
        }
    }
    let mut offset = [0.0, 0.0];
    let mut scale = [1.0, 1.0];
    let mut loc = None;
    o.props.retain(|p| {
        let slot = match p.name.as_str() {
            "uoffset" => &mut offset[0],
            "voffset" => &mut offset[1],
            "uscale" => &mut scale[0],
            "vscale" => &mut scale[1],
            _ => return true,
        };
        if let Value::Float(v) = p.value {
            *slot = v;
            loc.get_or_insert(p.loc.clone());
            false
        } else {
            true
        }
    });
    if let Some(loc) = loc {
        let m = DMat4::from_scale(glam::DVec3::new(scale[0], scale[1], 1.0))
            * DMat4::from_translation(glam::DVec3::new(offset[0], offset[1], 0.0));
        o.props.push(Prop {
            name: "to_uv".into(),
            value: Value::Transform(m),
            loc,
            used: Cell::new(false),
        });
    }
}

/// The file being read.
struct FileCtx<'a> {
    lines: &'a LineIndex,
    file: Rc<str>,
    dir: PathBuf,
    /// Version < 2: property names in camelCase.
    upgrade: bool,
}

impl FileCtx<'_> {
    fn loc(&self, node: roxmltree::Node) -> Loc {
        Loc {
            file: self.file.clone(),
            line: self.lines.line_of(node.range().start),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camel_case_names_are_upgraded_as_mitsuba_does() {
        assert_eq!(camel_to_snake("diffuseReflectance"), "diffuse_reflectance");
        assert_eq!(camel_to_snake("intIOR"), "int_ior");
        assert_eq!(camel_to_snake("maxDepth"), "max_depth");
        assert_eq!(camel_to_snake("already_snake"), "already_snake");
    }

    #[test]
    fn lines_are_roxmltrees_at_every_offset() {
        // The index against roxmltree's own count (newlines from the start), at every
        // byte of a file with CRLF and LF ends, blank lines and no final newline.
        let text =
            "<scene version=\"3.0.0\">\r\n\n  <shape type=\"cube\"/>\n\n\n<!-- é -->\n</scene>";
        let doc = roxmltree::Document::parse(text).unwrap();
        let lines = LineIndex::new(text);
        // At every character's first byte (roxmltree slices the text there; elements
        // start on one).
        for pos in (0..=text.len()).filter(|&p| text.is_char_boundary(p)) {
            assert_eq!(lines.line_of(pos), doc.text_pos_at(pos).row, "offset {pos}");
        }
        assert_eq!(lines.line_of(text.len()), 7);
    }

    #[test]
    fn versions_and_numbers() {
        assert_eq!(major_version("3.0.0"), Some(3));
        assert_eq!(major_version("0.6"), Some(0));
        assert_eq!(major_version("three"), None);
        assert_eq!(parse_vec3("1, 2 ,3").ok(), Some([1.0, 2.0, 3.0]));
        assert!(parse_vec3("1, 2").is_err());
        assert!(parse_f64("inf").is_err());
        assert!(parse_f64("1e400").is_err());
    }
}
