//! Directive processing: the graphics state, its stack, and the scene description being filled.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use geometry::Transform;
use glam::DVec3;
use scene::{
    CameraEntity, Diagnostic, Entity, InstanceUse, LightEntity, Loc, MaterialRef, MediumEntity, ObjectDefinition,
    OptionEntry, Param, ParamSet, ParamType, SceneDescription, ShapeEntity, TextureEntity, TextureValueType,
    TransformMotion,
};
use spectral::spectrum::PiecewiseLinear;
use spectral::Spectrum;

use crate::error::ParseError;
use crate::lexer::{Lexer, TokKind, Token};
use crate::params::{param_type, parse_integer, parse_number, read_spectrum_file};

type Result<T> = std::result::Result<T, ParseError>;

/// Targets of `Attribute`, in the order of [`GraphicsState::attributes`].
const ATTRIBUTE_TARGETS: [&str; 5] = ["shape", "light", "material", "medium", "texture"];
const SHAPE: usize = 0;
const LIGHT: usize = 1;
const MATERIAL: usize = 2;
const MEDIUM: usize = 3;
const TEXTURE: usize = 4;

/// Options pbrt-v4 knows (compared after lower-casing and removing '-' and '_').
const KNOWN_OPTIONS: [&str; 11] = [
    "disablepixeljitter",
    "disabletexturefiltering",
    "disablewavelengthjitter",
    "displacementedgescale",
    "msereferenceimage",
    "msereferenceout",
    "rendercoordsys",
    "seed",
    "forcediffuse",
    "pixelstats",
    "wavefront",
];

/// What `AttributeBegin` saves and `AttributeEnd` restores.
#[derive(Clone, Debug)]
struct GraphicsState {
    /// The current transform at the start time.
    ctm: Transform,
    /// The current transform at the end time (pbrt-v4 keeps two; they differ only after `ActiveTransform`).
    ctm_end: Transform,
    /// Which of the two transform directives change (`ActiveTransform StartTime|EndTime|All`).
    active: [bool; 2],
    reverse_orientation: bool,
    material: MaterialRef,
    area_light: Option<Entity>,
    inside_medium: Option<String>,
    outside_medium: Option<String>,
    attributes: [Vec<Param>; 5],
}

impl Default for GraphicsState {
    fn default() -> Self {
        Self {
            ctm: Transform::IDENTITY,
            ctm_end: Transform::IDENTITY,
            active: [true, true],
            reverse_orientation: false,
            material: MaterialRef::Anonymous(0),
            area_light: None,
            inside_medium: None,
            outside_medium: None,
            attributes: Default::default(),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Block {
    Attribute,
    Object,
}

/// One open file.
struct Source {
    lexer: Lexer,
    dir: Arc<Path>,
    /// For cycle detection.
    canonical: PathBuf,
    /// The `Include`/`Import` directive that opened it.
    included_from: Option<Loc>,
    /// For `Import`: the state to restore at its end, and the attribute stack depth it must end with.
    import: Option<(GraphicsState, usize)>,
}

pub(crate) struct Parser {
    files: Vec<Source>,
    peeked: Option<Token>,
    /// Location of the last token taken, for errors at the end of the input.
    last_loc: Loc,
    main_dir: Arc<Path>,
    scene: SceneDescription,
    gs: GraphicsState,
    stack: Vec<(GraphicsState, Block, Loc)>,
    /// Named coordinate systems: the start- and end-time transforms.
    named_coordinate_systems: HashMap<String, (Transform, Transform)>,
    /// `TransformTimes` (default 0 1).
    transform_times: (f64, f64),
    world_begin: Option<Loc>,
    named_materials: HashMap<String, Loc>,
    named_material_uses: Vec<(String, Loc)>,
    float_textures: HashMap<String, Loc>,
    spectrum_textures: HashMap<String, Loc>,
    media: HashMap<String, Loc>,
    medium_uses: Vec<(String, Loc)>,
    objects: HashMap<String, Loc>,
    active_object: Option<ObjectDefinition>,
    spectrum_files: HashMap<PathBuf, Spectrum>,
    warned_once: HashSet<&'static str>,
    /// Imported files that ended: the state to restore and the stack depth to check, applied once the directive
    /// being read when the file ended is complete (a parameter list may look ahead past the end of the file).
    pending_restores: Vec<(GraphicsState, usize, Arc<Path>)>,
}

fn dir_of(path: &Path) -> Arc<Path> {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => Arc::from(p),
        _ => Arc::from(Path::new(".")),
    }
}

fn canonical(path: &Path) -> PathBuf {
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
}

/// Reads a scene file's text (decompressing gzip data), with errors about the file as a whole at `at` (or at the
/// file itself).
pub(crate) fn read_text(path: &Path, at: Option<&Loc>) -> Result<String> {
    let file: Arc<Path> = Arc::from(path);
    let here = || at.cloned().unwrap_or_else(|| Loc::new(file.clone(), 1, 1));
    // Bounded, so that `Include "/dev/zero"` is an error rather than a read without end.
    let bytes = geometry::gzip::read_bounded(path, geometry::gzip::MAX_DECOMPRESSED_BYTES)
        .map_err(|e| ParseError::new(here(), format!("cannot read '{}': {e}", path.display())))?;
    decode_text(bytes, path, at)
}

/// A scene file's bytes as text: gzip data decompressed, UTF-16 refused, invalid UTF-8 reported at its line and
/// column; errors about the file as a whole are at `at` (or at the file itself).
pub(crate) fn decode_text(mut bytes: Vec<u8>, path: &Path, at: Option<&Loc>) -> Result<String> {
    let file: Arc<Path> = Arc::from(path);
    let here = || at.cloned().unwrap_or_else(|| Loc::new(file.clone(), 1, 1));
    // pbrt-v4 reads gzip-compressed scene files (`.pbrt.gz`); recognised by content, so a misnamed file works too.
    // Locations then name the compressed file and the line and column in its decompressed text.
    if geometry::gzip::is_gzip(&bytes) {
        bytes = geometry::gzip::gunzip(&bytes, geometry::gzip::MAX_DECOMPRESSED_BYTES)
            .map_err(|e| ParseError::new(here(), format!("cannot read '{}': {e}", path.display())))?;
    }
    if bytes.starts_with(&[0xfe, 0xff]) || bytes.starts_with(&[0xff, 0xfe]) {
        return Err(ParseError::new(
            Loc::new(file.clone(), 1, 1),
            "the file is encoded in UTF-16, which is not supported; convert it to UTF-8",
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        let good = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = 1 + good.iter().filter(|&&b| b == b'\n').count() as u32;
        let last = good.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        let column = 1 + std::str::from_utf8(&good[last..]).map_or(0, |s| s.chars().count()) as u32;
        ParseError::new(Loc::new(file.clone(), line, column), "the file is not valid UTF-8 text")
    })
}

impl Parser {
    pub fn new(main_file: &Path, text: String) -> Self {
        let file: Arc<Path> = Arc::from(main_file);
        let main_dir = dir_of(main_file);
        let source = Source {
            lexer: Lexer::new(text, file.clone()),
            dir: main_dir.clone(),
            canonical: canonical(main_file),
            included_from: None,
            import: None,
        };
        Self {
            files: vec![source],
            peeked: None,
            last_loc: Loc::new(file.clone(), 1, 1),
            main_dir,
            scene: SceneDescription::new(file),
            gs: GraphicsState::default(),
            stack: Vec::new(),
            named_coordinate_systems: HashMap::new(),
            transform_times: (0.0, 1.0),
            world_begin: None,
            named_materials: HashMap::new(),
            named_material_uses: Vec::new(),
            float_textures: HashMap::new(),
            spectrum_textures: HashMap::new(),
            media: HashMap::new(),
            medium_uses: Vec::new(),
            objects: HashMap::new(),
            active_object: None,
            spectrum_files: HashMap::new(),
            warned_once: HashSet::new(),
            pending_restores: Vec::new(),
        }
    }

    /// Parses everything and checks what can only be checked at the end.
    pub fn run(mut self) -> Result<SceneDescription> {
        let r = self.parse_all();
        match r {
            Ok(()) => Ok(self.scene),
            Err(mut e) => {
                if e.included_from.is_empty() {
                    e.included_from = self.include_chain();
                }
                Err(e)
            }
        }
    }

    fn include_chain(&self) -> Vec<Loc> {
        self.files.iter().rev().filter_map(|s| s.included_from.clone()).collect()
    }

    // ----------------------------------------------------------------------------------------------------------
    // Tokens across the file stack

    fn next(&mut self) -> Result<Option<Token>> {
        if let Some(t) = self.peeked.take() {
            return Ok(Some(t));
        }
        loop {
            let Some(top) = self.files.last_mut() else { return Ok(None) };
            match top.lexer.next_token()? {
                Some(t) => {
                    self.last_loc = t.loc.clone();
                    return Ok(Some(t));
                }
                None => self.end_of_file()?,
            }
        }
    }

    fn peek(&mut self) -> Result<Option<&Token>> {
        if self.peeked.is_none() {
            self.peeked = self.next()?;
        }
        Ok(self.peeked.as_ref())
    }

    fn end_of_file(&mut self) -> Result<()> {
        if let Some(src) = self.files.pop() {
            if let Some((gs, depth)) = src.import {
                self.pending_restores.push((gs, depth, src.lexer.file().clone()));
            }
        }
        Ok(())
    }

    /// Restores the graphics state saved by `Import`s whose files have ended.
    fn apply_pending_restores(&mut self) -> Result<()> {
        while let Some((gs, depth, file)) = self.pending_restores.pop() {
            if self.stack.len() > depth {
                let (_, kind, loc) = &self.stack[self.stack.len() - 1];
                let what = if *kind == Block::Object { "ObjectBegin" } else { "AttributeBegin" };
                return Err(ParseError::new(
                    loc.clone(),
                    format!("{what} is not closed by the end of the imported file '{}'", file.display()),
                ));
            }
            self.gs = gs;
        }
        Ok(())
    }

    fn eof_error(&self, expected: &str) -> ParseError {
        ParseError::new(self.last_loc.clone(), format!("unexpected end of file: expected {expected}"))
    }

    fn expect_string(&mut self, what: &str) -> Result<(String, Loc)> {
        match self.next()? {
            Some(Token { kind: TokKind::Str(s), loc }) => Ok((s, loc)),
            Some(t) => Err(ParseError::new(
                t.loc.clone(),
                format!("expected {what} (a quoted string), found {}", t.describe()),
            )),
            None => Err(self.eof_error(&format!("{what} (a quoted string)"))),
        }
    }

    /// `n` numbers for a directive, optionally in brackets.
    fn numbers<const N: usize>(&mut self, directive: &str) -> Result<[f64; N]> {
        let bracketed = matches!(self.peek()?, Some(Token { kind: TokKind::Open, .. }));
        if bracketed {
            self.next()?;
        }
        let mut v = [0.0; N];
        for (i, slot) in v.iter_mut().enumerate() {
            match self.next()? {
                Some(Token { kind: TokKind::Word(w), loc }) => *slot = parse_number(&w, &loc)?,
                Some(t) => {
                    return Err(ParseError::new(
                        t.loc.clone(),
                        format!("{directive} takes {N} numbers; expected number {} but found {}", i + 1, t.describe()),
                    ))
                }
                None => return Err(self.eof_error(&format!("{N} numbers for {directive}"))),
            }
        }
        if bracketed {
            match self.next()? {
                Some(Token { kind: TokKind::Close, .. }) => {}
                Some(t) => {
                    return Err(ParseError::new(
                        t.loc.clone(),
                        format!("{directive} takes {N} numbers; expected ']' but found {}", t.describe()),
                    ))
                }
                None => return Err(self.eof_error("']'")),
            }
        }
        Ok(v)
    }

    fn warn(&mut self, loc: &Loc, message: impl Into<String>) {
        self.scene.warnings.push(Diagnostic::new(loc.clone(), message));
    }

    /// pbrt-v4 accepts singular transforms (an axis scaled to zero, common in exported scenes); say what follows.
    fn warn_singular(&mut self, what: &str, loc: &Loc) {
        self.warn(
            loc,
            format!(
                "{what} makes the transform singular (some direction is scaled to zero); accepted as pbrt-v4 does: \
                 meshes under it are flattened and shaded with their geometric normals, while other shapes, object \
                 instances and lights other than point lights under it are left out"
            ),
        );
    }

    /// Under a singular CTM, pbrt-v4's inverse is NaN: things that need it (rays into an analytic shape's or an
    /// instance's space, a light's directions) never contribute. They are left out with a warning; true if so.
    fn skip_under_singular_ctm(&mut self, what: &str, loc: &Loc) -> bool {
        if self.gs.ctm.is_invertible() && self.gs.ctm_end.is_invertible() {
            return false;
        }
        self.warn(loc, format!("{what} under a singular transform is left out (it needs the transform's inverse, which does not exist; pbrt-v4 renders nothing of it either)"));
        true
    }

    fn warn_once(&mut self, key: &'static str, loc: &Loc, message: impl Into<String>) {
        if self.warned_once.insert(key) {
            self.warn(loc, message);
        }
    }

    // ----------------------------------------------------------------------------------------------------------
    // Parameters

    /// The parameter list following a directive: every `"type name" value(s)` up to the next non-string token.
    fn params(&mut self) -> Result<Vec<Param>> {
        let mut out: Vec<Param> = Vec::new();
        while let Some(Token { kind: TokKind::Str(_), .. }) = self.peek()? {
            let Some(Token { kind: TokKind::Str(decl), loc }) = self.next()? else { unreachable!() };
            let p = self.param(&decl, loc)?;
            if let Some(prev) = out.iter().find(|q| q.name == p.name) {
                let msg =
                    format!("parameter '{}' is given again (first at {}); the last value is used", p.name, prev.loc);
                self.warn(&p.loc, msg);
            }
            out.push(p);
        }
        Ok(out)
    }

    fn param(&mut self, decl: &str, loc: Loc) -> Result<Param> {
        let words: Vec<&str> = decl.split_whitespace().collect();
        let [ty_name, name] = words[..] else {
            return Err(ParseError::new(
                loc,
                format!("parameter declaration \"{decl}\" must be a type and a name, such as \"float radius\""),
            ));
        };
        let Some((ty, synonym)) = param_type(ty_name) else {
            return Err(ParseError::new(
                loc,
                format!(
                    "unknown parameter type '{ty_name}' in \"{decl}\" (known: float, integer, bool, string, point2, \
                     vector2, point3, vector3, normal, rgb, spectrum, blackbody, texture)"
                ),
            ));
        };
        if let Some(v4) = synonym {
            self.warn(&loc, format!("parameter type '{ty_name}' is pbrt-v3 syntax; read as '{v4}'"));
        }
        let mut p = Param::new(ty, name, loc.clone());
        let dir = dir_of(&loc.file);
        p.search_dirs.push(dir.clone());
        if dir != self.main_dir {
            p.search_dirs.push(self.main_dir.clone());
        }

        // The values: one token, or a bracketed list.
        let mut values: Vec<Token> = Vec::new();
        match self.next()? {
            Some(Token { kind: TokKind::Open, loc: open }) => loop {
                match self.next()? {
                    Some(Token { kind: TokKind::Close, .. }) => break,
                    Some(t @ Token { kind: TokKind::Open, .. }) => {
                        return Err(ParseError::new(
                            t.loc,
                            format!("'[' inside the value list of \"{decl}\" (opened at {open})"),
                        ))
                    }
                    Some(t) => values.push(t),
                    None => {
                        return Err(ParseError::new(
                            open,
                            format!("unterminated '[': the value list of \"{decl}\" has no closing ']'"),
                        ))
                    }
                }
            },
            Some(t @ Token { kind: TokKind::Str(_) | TokKind::Word(_), .. }) => values.push(t),
            Some(t) => {
                return Err(ParseError::new(
                    t.loc.clone(),
                    format!("expected a value for \"{decl}\", found {}", t.describe()),
                ))
            }
            None => return Err(self.eof_error(&format!("a value for \"{decl}\""))),
        }

        let expect = |t: &Token, what: &str| {
            ParseError::new(t.loc.clone(), format!("parameter \"{decl}\" expects {what}, found {}", t.describe()))
        };
        match ty {
            ParamType::Integer => {
                for t in &values {
                    match &t.kind {
                        TokKind::Word(w) => p.ints.push(parse_integer(w, &t.loc)?),
                        _ => return Err(expect(t, "integers")),
                    }
                }
            }
            ParamType::Bool => {
                for t in &values {
                    match &t.kind {
                        TokKind::Word(w) | TokKind::Str(w) if w == "true" => p.bools.push(true),
                        TokKind::Word(w) | TokKind::Str(w) if w == "false" => p.bools.push(false),
                        _ => return Err(expect(t, "true or false")),
                    }
                }
            }
            ParamType::String | ParamType::Texture => {
                for t in &values {
                    match &t.kind {
                        TokKind::Str(s) => p.strings.push(s.clone()),
                        _ => return Err(expect(t, "quoted strings")),
                    }
                }
            }
            ParamType::Spectrum if matches!(values.first(), Some(Token { kind: TokKind::Str(_), .. })) => {
                for t in &values {
                    match &t.kind {
                        TokKind::Str(s) => {
                            let spectrum = self.named_or_file_spectrum(s, &t.loc, &dir)?;
                            p.strings.push(s.clone());
                            p.spectra.push(spectrum);
                        }
                        _ => return Err(expect(t, "a spectrum name or file name (not mixed with numbers)")),
                    }
                }
            }
            _ => {
                for t in &values {
                    match &t.kind {
                        TokKind::Word(w) => p.floats.push(parse_number(w, &t.loc)?),
                        _ => return Err(expect(t, "numbers")),
                    }
                }
                let n = ty.numbers_per_value();
                if !p.floats.len().is_multiple_of(n) {
                    return Err(ParseError::new(
                        loc,
                        format!("parameter \"{decl}\" has {} numbers, which is not a multiple of {n}", p.floats.len()),
                    ));
                }
                match ty {
                    ParamType::Spectrum => {
                        PiecewiseLinear::from_interleaved(&p.floats).map_err(|e| {
                            ParseError::new(loc.clone(), format!("parameter \"{decl}\": {e} (expected λ value pairs)"))
                        })?;
                    }
                    ParamType::Blackbody if p.floats.len() == 2 => {
                        self.warn(&loc, format!("\"{decl}\": pbrt-v3's second blackbody value (a scale) is applied, but is deprecated; use \"float scale\""));
                    }
                    ParamType::Blackbody if p.floats.len() != 1 => {
                        return Err(ParseError::new(
                            loc,
                            format!(
                                "parameter \"{decl}\" takes one temperature in kelvin, got {} values",
                                p.floats.len()
                            ),
                        ));
                    }
                    ParamType::Blackbody if p.floats[0] <= 0.0 => {
                        return Err(ParseError::new(
                            loc,
                            format!("parameter \"{decl}\": temperature must be positive"),
                        ));
                    }
                    _ => {}
                }
            }
        }
        Ok(p)
    }

    /// A spectrum by name (CIE illuminants, then the optical catalogue's `glass-*`/`metal-*`), else from a file of
    /// λ/value pairs relative to `dir` (then to the main file's directory).
    fn named_or_file_spectrum(&mut self, name: &str, loc: &Loc, dir: &Arc<Path>) -> Result<Spectrum> {
        if let Ok(s) = spectral::named::illuminant(name) {
            return Ok(s);
        }
        let named_err = match optics::catalogue::named_spectrum_checked(name) {
            Ok(s) => return Ok(s),
            Err(e @ optics::OpticsError::UnknownName { .. }) => e.to_string(),
            Err(e) => return Err(ParseError::new(loc.clone(), format!("spectrum '{name}': {e}"))),
        };
        let rel = Path::new(name);
        let mut candidates = vec![dir.join(rel)];
        if **dir != *self.main_dir {
            candidates.push(self.main_dir.join(rel));
        }
        let Some(path) = candidates.iter().find(|c| c.is_file()).cloned() else {
            return Err(ParseError::new(
                loc.clone(),
                format!(
                    "spectrum '{name}' is neither a named spectrum ({named_err}) nor a file ('{}' not found)",
                    candidates[0].display()
                ),
            ));
        };
        let key = canonical(&path);
        if let Some(s) = self.spectrum_files.get(&key) {
            return Ok(s.clone());
        }
        let values = read_spectrum_file(&path, Arc::from(path.as_path()))
            .map_err(|m| ParseError::new(loc.clone(), format!("spectrum file '{name}': {m}")))?;
        let table = PiecewiseLinear::from_interleaved(&values).map_err(|e| {
            ParseError::new(loc.clone(), format!("spectrum file '{}': {e} (expected λ value pairs)", path.display()))
        })?;
        let s = Spectrum::PiecewiseLinear(Arc::new(table));
        self.scene.files.push(path.clone());
        self.spectrum_files.insert(key, s.clone());
        Ok(s)
    }

    /// A parameter set: the `Attribute` defaults for `target` (if any), then the directive's own parameters.
    fn param_set(&self, target: Option<usize>, own: Vec<Param>) -> ParamSet {
        let mut v: Vec<Param> = target.map(|t| self.gs.attributes[t].clone()).unwrap_or_default();
        v.extend(own);
        ParamSet::from_params(v)
    }

    // ----------------------------------------------------------------------------------------------------------
    // Directives

    fn require_options(&self, directive: &str, loc: &Loc) -> Result<()> {
        match &self.world_begin {
            Some(wb) => Err(ParseError::new(
                loc.clone(),
                format!("{directive} is not allowed after WorldBegin (at {wb}); it must come before it"),
            )),
            None => Ok(()),
        }
    }

    fn require_world(&self, directive: &str, loc: &Loc) -> Result<()> {
        if self.world_begin.is_none() {
            return Err(ParseError::new(loc.clone(), format!("{directive} is only allowed after WorldBegin")));
        }
        Ok(())
    }

    /// Applies a transform directive to the active transforms (pbrt-v4's `ForActiveTransforms`).
    fn apply(&mut self, t: Transform, replace: bool) {
        let [start, end] = self.gs.active;
        if start {
            self.gs.ctm = if replace { t } else { self.gs.ctm * t };
        }
        if end {
            self.gs.ctm_end = if replace { t } else { self.gs.ctm_end * t };
        }
    }

    /// The end of the current transform if it differs from the start (pbrt-v4's `CTMIsAnimated`).
    fn motion(&self, start: &Transform, end: Transform) -> Option<TransformMotion> {
        let (start_time, end_time) = self.transform_times;
        (end.matrix() != start.matrix()).then_some(TransformMotion { end, start_time, end_time })
    }

    /// pbrt-v4 uses only the start transform of lights, textures and media: say so when the end differs.
    fn warn_start_only(&mut self, what: &str, loc: &Loc) {
        if self.gs.ctm.matrix() != self.gs.ctm_end.matrix() {
            self.warn(
                loc,
                format!("{what} under a moving transform: only the start-time transform is used (as in pbrt-v4)"),
            );
        }
    }

    fn parse_all(&mut self) -> Result<()> {
        while let Some(tok) = self.next()? {
            let (word, loc) = match tok.kind {
                TokKind::Word(w) => (w, tok.loc),
                _ => {
                    return Err(ParseError::new(
                        tok.loc.clone(),
                        format!("expected a directive, found {}", tok.describe()),
                    ))
                }
            };
            self.apply_pending_restores()?;
            self.directive(&word, loc)?;
            self.apply_pending_restores()?;
        }
        self.apply_pending_restores()?;
        self.finish()
    }

    fn directive(&mut self, word: &str, loc: Loc) -> Result<()> {
        match word {
            // Transforms
            "Identity" => self.apply(Transform::IDENTITY, true),
            "Translate" => {
                let [x, y, z] = self.numbers::<3>(word)?;
                self.apply(Transform::translate(DVec3::new(x, y, z)), false);
            }
            "Scale" => {
                let [x, y, z] = self.numbers::<3>(word)?;
                let t = match Transform::scale(DVec3::new(x, y, z)) {
                    Some(t) => t,
                    None => {
                        self.warn_singular(&format!("Scale {x} {y} {z}: a zero factor"), &loc);
                        Transform::from_matrix_allow_singular(glam::DMat4::from_scale(DVec3::new(x, y, z)))
                            .ok_or_else(|| ParseError::new(loc.clone(), "Scale: the factors are not finite"))?
                    }
                };
                self.apply(t, false);
            }
            "Rotate" => {
                let [a, x, y, z] = self.numbers::<4>(word)?;
                let t = Transform::rotate(a, DVec3::new(x, y, z))
                    .ok_or_else(|| ParseError::new(loc.clone(), "Rotate: the rotation axis is the zero vector"))?;
                self.apply(t, false);
            }
            "LookAt" => {
                let v = self.numbers::<9>(word)?;
                let (eye, look, up) =
                    (DVec3::new(v[0], v[1], v[2]), DVec3::new(v[3], v[4], v[5]), DVec3::new(v[6], v[7], v[8]));
                let t = Transform::look_at(eye, look, up).ok_or_else(|| {
                    ParseError::new(
                        loc.clone(),
                        "LookAt: degenerate (eye equals look, or up is zero or parallel to the viewing direction)",
                    )
                })?;
                self.apply(t, false);
            }
            "Transform" | "ConcatTransform" => {
                let m = self.numbers::<16>(word)?;
                let t = match Transform::from_pbrt_array(&m) {
                    Some(t) => t,
                    None => {
                        self.warn_singular(&format!("{word}: the matrix"), &loc);
                        Transform::from_matrix_allow_singular(glam::DMat4::from_cols_array(&m))
                            .ok_or_else(|| ParseError::new(loc.clone(), format!("{word}: the matrix is not finite")))?
                    }
                };
                self.apply(t, word == "Transform");
            }
            "CoordinateSystem" => {
                let (name, _) = self.expect_string("a coordinate system name")?;
                self.named_coordinate_systems.insert(name, (self.gs.ctm, self.gs.ctm_end));
            }
            "CoordSysTransform" => {
                let (name, nloc) = self.expect_string("a coordinate system name")?;
                match self.named_coordinate_systems.get(&name) {
                    // Both transforms, whatever is active (pbrt-v4 assigns the whole pair).
                    Some(&(start, end)) => {
                        self.gs.ctm = start;
                        self.gs.ctm_end = end;
                    }
                    None => {
                        self.warn(&nloc, format!("CoordSysTransform: no coordinate system named '{name}'; ignored"))
                    }
                }
            }
            "ActiveTransform" => {
                let which = match self.next()? {
                    Some(Token { kind: TokKind::Word(w), .. })
                        if matches!(w.as_str(), "All" | "StartTime" | "EndTime") =>
                    {
                        w
                    }
                    Some(t) => {
                        return Err(ParseError::new(
                            t.loc.clone(),
                            format!("ActiveTransform takes All, StartTime or EndTime, found {}", t.describe()),
                        ))
                    }
                    None => return Err(self.eof_error("All, StartTime or EndTime")),
                };
                self.gs.active = match which.as_str() {
                    "StartTime" => [true, false],
                    "EndTime" => [false, true],
                    _ => [true, true],
                };
            }
            "TransformTimes" => {
                self.require_options(word, &loc)?;
                let [start, end] = self.numbers::<2>(word)?;
                if end < start {
                    return Err(ParseError::new(
                        loc,
                        format!("TransformTimes: the end time ({end}) is before the start time ({start})"),
                    ));
                }
                self.transform_times = (start, end);
            }
            "ReverseOrientation" => {
                self.require_world(word, &loc)?;
                self.gs.reverse_orientation = !self.gs.reverse_orientation;
            }

            // Options
            "Camera" => {
                self.require_options(word, &loc)?;
                let (name, _) = self.expect_string("a camera type")?;
                let params = self.params()?;
                if !self.scene.camera.entity.loc.is_builtin() {
                    self.warn(&loc, format!("a second Camera replaces the one at {}", self.scene.camera.entity.loc));
                }
                let camera_from_world = self.gs.ctm;
                let camera_from_world_end = self.gs.ctm_end;
                if !camera_from_world.is_invertible() || !camera_from_world_end.is_invertible() {
                    return Err(ParseError::new(
                        loc,
                        "the camera transform is singular (some direction is scaled to zero), so the camera has no \
                         position and orientation in the world",
                    ));
                }
                self.named_coordinate_systems
                    .insert("camera".to_owned(), (camera_from_world.inverse(), camera_from_world_end.inverse()));
                let medium = self.gs.outside_medium.clone();
                if let Some(m) = &medium {
                    self.medium_uses.push((m.clone(), loc.clone()));
                }
                self.scene.camera = CameraEntity {
                    entity: Entity::new(name, ParamSet::from_params(params), loc),
                    camera_from_world,
                    medium,
                    motion: self.motion(&camera_from_world, camera_from_world_end),
                };
            }
            "Film" | "Sampler" | "Integrator" | "PixelFilter" | "Accelerator" => {
                self.require_options(word, &loc)?;
                let (name, _) = self.expect_string(&format!("a {word} type"))?;
                let e = Entity::new(name, ParamSet::from_params(self.params()?), loc.clone());
                let slot = match word {
                    "Film" => &mut self.scene.film,
                    "Sampler" => &mut self.scene.sampler,
                    "Integrator" => &mut self.scene.integrator,
                    "PixelFilter" => &mut self.scene.filter,
                    _ => {
                        if let Some(prev) = &self.scene.accelerator {
                            let msg = format!("a second Accelerator replaces the one at {}", prev.loc);
                            self.warn(&loc, msg);
                        }
                        self.scene.accelerator = Some(e);
                        return Ok(());
                    }
                };
                let prev = std::mem::replace(slot, e);
                if !prev.loc.is_builtin() {
                    self.warn(&loc, format!("a second {word} replaces the one at {}", prev.loc));
                }
            }
            "ColorSpace" => {
                let (name, nloc) = self.expect_string("a colour space name")?;
                if name != "srgb" {
                    return Err(ParseError::new(
                        nloc,
                        format!("unsupported colour space '{name}': only \"srgb\" is supported (pbrt-v4 also knows aces2065-1, rec2020, dci-p3)"),
                    ));
                }
                self.scene.color_space = name;
            }
            "Option" => {
                let (decl, _) = self.expect_string("an option name")?;
                let value = match self.next()? {
                    Some(Token { kind: TokKind::Word(w) | TokKind::Str(w), .. }) => w,
                    Some(t) => {
                        return Err(ParseError::new(
                            t.loc.clone(),
                            format!("expected a value for Option \"{decl}\", found {}", t.describe()),
                        ))
                    }
                    None => return Err(self.eof_error("an option value")),
                };
                let name = decl.split_whitespace().last().unwrap_or("").to_owned();
                let normalized: String =
                    name.chars().filter(|c| *c != '-' && *c != '_').collect::<String>().to_lowercase();
                if !KNOWN_OPTIONS.contains(&normalized.as_str()) {
                    self.warn(&loc, format!("unknown Option '{name}'"));
                }
                self.scene.options.push(OptionEntry { name, value, loc });
            }
            "MakeNamedMedium" => {
                let (name, _) = self.expect_string("a medium name")?;
                let own = self.params()?;
                if let Some(prev) = self.media.get(&name) {
                    return Err(ParseError::new(loc, format!("medium '{name}' is defined again (first at {prev})")));
                }
                let params = self.param_set(Some(MEDIUM), own);
                let ty = params.get_string("type", "")?;
                if ty.is_empty() {
                    return Err(ParseError::new(
                        loc,
                        format!("MakeNamedMedium '{name}' has no \"string type\" parameter"),
                    ));
                }
                self.media.insert(name.clone(), loc.clone());
                self.warn_start_only("MakeNamedMedium", &loc);
                self.scene.media.push(MediumEntity {
                    entity: Entity::new(ty, params, loc),
                    medium_name: name,
                    render_from_medium: self.gs.ctm,
                });
            }
            "MediumInterface" => {
                let (inside, _) = self.expect_string("the interior medium's name")?;
                let outside = match self.peek()? {
                    Some(Token { kind: TokKind::Str(_), .. }) => self.expect_string("the exterior medium's name")?.0,
                    _ => inside.clone(),
                };
                let some = |s: String| (!s.is_empty()).then_some(s);
                self.gs.inside_medium = some(inside);
                self.gs.outside_medium = some(outside);
                for m in [&self.gs.inside_medium, &self.gs.outside_medium].into_iter().flatten() {
                    self.medium_uses.push((m.clone(), loc.clone()));
                }
            }
            "WorldBegin" => {
                if let Some(prev) = &self.world_begin {
                    return Err(ParseError::new(loc, format!("WorldBegin given twice (first at {prev})")));
                }
                self.world_begin = Some(loc);
                self.gs.ctm = Transform::IDENTITY;
                self.gs.ctm_end = Transform::IDENTITY;
                self.gs.active = [true, true];
                self.named_coordinate_systems.insert("world".to_owned(), (Transform::IDENTITY, Transform::IDENTITY));
            }
            "WorldEnd" => {
                self.require_world(word, &loc)?;
                self.warn(&loc, "WorldEnd is pbrt-v3 syntax; ignored");
            }

            // Attributes
            "AttributeBegin" | "TransformBegin" => {
                if word == "TransformBegin" {
                    self.warn_once(
                        "transformbegin",
                        &loc,
                        "TransformBegin/TransformEnd are deprecated; they act as AttributeBegin/AttributeEnd",
                    );
                } else {
                    self.require_world(word, &loc)?;
                }
                self.stack.push((self.gs.clone(), Block::Attribute, loc));
            }
            "AttributeEnd" | "TransformEnd" => {
                if word == "AttributeEnd" {
                    self.require_world(word, &loc)?;
                }
                let open = if word == "AttributeEnd" { "AttributeBegin" } else { "TransformBegin" };
                let floor = self.files.iter().filter_map(|s| s.import.as_ref().map(|i| i.1)).max().unwrap_or(0);
                match self.stack.last() {
                    None => return Err(ParseError::new(loc, format!("{word} without a matching {open}"))),
                    Some((_, _, _)) if self.stack.len() <= floor => {
                        return Err(ParseError::new(
                            loc,
                            format!("{word} closes a block opened outside this imported file"),
                        ))
                    }
                    Some((_, Block::Object, oloc)) => {
                        return Err(ParseError::new(loc, format!("{word} while the ObjectBegin at {oloc} is open")))
                    }
                    Some(_) => {
                        let (gs, _, _) = self.stack.pop().expect("checked non-empty");
                        self.gs = gs;
                    }
                }
            }
            "Attribute" => {
                let (target, tloc) = self.expect_string("an attribute target")?;
                let Some(i) = ATTRIBUTE_TARGETS.iter().position(|t| *t == target) else {
                    return Err(ParseError::new(
                        tloc,
                        format!("unknown Attribute target '{target}': expected \"shape\", \"light\", \"material\", \"medium\" or \"texture\""),
                    ));
                };
                for mut p in self.params()? {
                    p.may_be_unused = true;
                    self.gs.attributes[i].push(p);
                }
            }

            // Materials and textures
            "Material" => {
                self.require_world(word, &loc)?;
                let (name, _) = self.expect_string("a material type")?;
                let own = self.params()?;
                let e = Entity::new(name, self.param_set(Some(MATERIAL), own), loc);
                self.scene.materials.push(e);
                self.gs.material = MaterialRef::Anonymous(self.scene.materials.len() - 1);
            }
            "MakeNamedMaterial" => {
                self.require_world(word, &loc)?;
                let (name, _) = self.expect_string("a material name")?;
                let own = self.params()?;
                if let Some(prev) = self.named_materials.get(&name) {
                    return Err(ParseError::new(
                        loc,
                        format!("named material '{name}' is defined again (first at {prev})"),
                    ));
                }
                let params = self.param_set(Some(MATERIAL), own);
                let ty = params.get_string("type", "")?;
                if ty.is_empty() {
                    return Err(ParseError::new(
                        loc,
                        format!("MakeNamedMaterial '{name}' has no \"string type\" parameter"),
                    ));
                }
                self.named_materials.insert(name.clone(), loc.clone());
                self.scene.named_materials.push((name, Entity::new(ty, params, loc)));
            }
            "NamedMaterial" => {
                self.require_world(word, &loc)?;
                let (name, nloc) = self.expect_string("a material name")?;
                self.named_material_uses.push((name.clone(), nloc));
                self.gs.material = MaterialRef::Named(name);
            }
            "Texture" => {
                self.require_world(word, &loc)?;
                let (name, _) = self.expect_string("a texture name")?;
                let (ty, tloc) = self.expect_string("a texture value type (\"float\" or \"spectrum\")")?;
                let (class, _) = self.expect_string("a texture class")?;
                let own = self.params()?;
                let value_type = match ty.as_str() {
                    "float" => TextureValueType::Float,
                    "spectrum" => TextureValueType::Spectrum,
                    "color" => {
                        self.warn(&tloc, "texture type \"color\" is pbrt-v3 syntax; read as \"spectrum\"");
                        TextureValueType::Spectrum
                    }
                    _ => {
                        return Err(ParseError::new(
                            tloc,
                            format!("unknown texture type '{ty}': expected \"float\" or \"spectrum\""),
                        ))
                    }
                };
                let names = if value_type == TextureValueType::Float {
                    &mut self.float_textures
                } else {
                    &mut self.spectrum_textures
                };
                if let Some(prev) = names.get(&name) {
                    return Err(ParseError::new(
                        loc,
                        format!("{ty} texture '{name}' is defined again (first at {prev})"),
                    ));
                }
                names.insert(name.clone(), loc.clone());
                let params = self.param_set(Some(TEXTURE), own);
                self.warn_start_only("Texture", &loc);
                self.scene.textures.push(TextureEntity {
                    entity: Entity::new(class, params, loc),
                    texture_name: name,
                    value_type,
                    render_from_texture: self.gs.ctm,
                });
            }

            // Lights and shapes
            "LightSource" => {
                self.require_world(word, &loc)?;
                let (name, _) = self.expect_string("a light type")?;
                let own = self.params()?;
                // A point light needs only its position, which a singular transform still maps.
                if name != "point" && self.skip_under_singular_ctm(&format!("LightSource \"{name}\""), &loc) {
                    return Ok(());
                }
                let params = self.param_set(Some(LIGHT), own);
                self.warn_start_only("LightSource", &loc);
                self.scene.lights.push(LightEntity {
                    entity: Entity::new(name, params, loc),
                    render_from_light: self.gs.ctm,
                    medium: self.gs.outside_medium.clone(),
                });
            }
            "AreaLightSource" => {
                self.require_world(word, &loc)?;
                let (name, _) = self.expect_string("an area light type")?;
                let own = self.params()?;
                self.gs.area_light = Some(Entity::new(name, self.param_set(Some(LIGHT), own), loc));
            }
            "Shape" => {
                self.require_world(word, &loc)?;
                let (name, _) = self.expect_string("a shape type")?;
                let own = self.params()?;
                // Meshes are transformed to render space vertex by vertex, so a singular transform flattens them;
                // the other shapes are intersected in object space, which a singular transform has none of.
                let mesh = matches!(name.as_str(), "trianglemesh" | "plymesh" | "loopsubdiv" | "bilinearmesh");
                if !mesh && self.skip_under_singular_ctm(&format!("Shape \"{name}\""), &loc) {
                    return Ok(());
                }
                let mut area_light = self.gs.area_light.clone();
                if self.active_object.is_some() && area_light.is_some() {
                    self.warn(&loc, "area lights are not supported inside object definitions (as in pbrt-v4); this shape does not emit");
                    area_light = None;
                }
                let shape = ShapeEntity {
                    entity: Entity::new(name, self.param_set(Some(SHAPE), own), loc),
                    render_from_object: self.gs.ctm,
                    reverse_orientation: self.gs.reverse_orientation,
                    material: self.gs.material.clone(),
                    area_light,
                    inside_medium: self.gs.inside_medium.clone(),
                    outside_medium: self.gs.outside_medium.clone(),
                    motion: self.motion(&self.gs.ctm, self.gs.ctm_end),
                };
                match &mut self.active_object {
                    Some(o) => o.shapes.push(shape),
                    None => self.scene.shapes.push(shape),
                }
            }

            // Instancing
            "ObjectBegin" => {
                self.require_world(word, &loc)?;
                let (name, _) = self.expect_string("an object name")?;
                if let Some(o) = &self.active_object {
                    return Err(ParseError::new(
                        loc,
                        format!("ObjectBegin inside the definition of object '{}' (at {})", o.name, o.loc),
                    ));
                }
                if let Some(prev) = self.objects.get(&name) {
                    return Err(ParseError::new(loc, format!("object '{name}' is defined again (first at {prev})")));
                }
                self.objects.insert(name.clone(), loc.clone());
                self.stack.push((self.gs.clone(), Block::Object, loc.clone()));
                self.active_object = Some(ObjectDefinition { name, shapes: Vec::new(), loc });
            }
            "ObjectEnd" => {
                self.require_world(word, &loc)?;
                let Some(def) = self.active_object.take() else {
                    return Err(ParseError::new(loc, "ObjectEnd without a matching ObjectBegin"));
                };
                match self.stack.pop() {
                    Some((gs, Block::Object, _)) => self.gs = gs,
                    Some((_, Block::Attribute, aloc)) => {
                        return Err(ParseError::new(
                            loc,
                            format!("ObjectEnd while the AttributeBegin at {aloc} is open"),
                        ))
                    }
                    None => return Err(ParseError::new(loc, "ObjectEnd without a matching ObjectBegin")),
                }
                self.scene.objects.push(def);
            }
            "ObjectInstance" => {
                self.require_world(word, &loc)?;
                let (name, _) = self.expect_string("an object name")?;
                if let Some(o) = &self.active_object {
                    return Err(ParseError::new(
                        loc,
                        format!("ObjectInstance inside the definition of object '{}' (at {})", o.name, o.loc),
                    ));
                }
                if self.skip_under_singular_ctm(&format!("ObjectInstance \"{name}\""), &loc) {
                    return Ok(());
                }
                let motion = self.motion(&self.gs.ctm, self.gs.ctm_end);
                self.scene.instances.push(InstanceUse { name, render_from_instance: self.gs.ctm, loc, motion });
            }

            // Files
            "Include" | "Import" => {
                let (name, _) = self.expect_string("a file name")?;
                if word == "Import" {
                    self.require_world(word, &loc)?;
                    let ext = Path::new(&name).extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
                    if matches!(ext.as_deref(), Some("gltf" | "glb")) {
                        // Prismatic's extension: a glTF file's meshes, materials and lights under the current
                        // transform (its cameras are not used: the pbrt file has its own).
                        let path = self.resolve(&name);
                        if self.skip_under_singular_ctm(&format!("Import \"{name}\""), &loc) {
                            return Ok(());
                        }
                        let ctm = self.gs.ctm;
                        gltf_import::import(&mut self.scene, &path, &ctm)
                            .map_err(|e| ParseError::new(loc.clone(), e.to_string()))?;
                        return Ok(());
                    }
                }
                self.open_file(&name, loc, word == "Import")?;
            }

            _ => {
                return Err(ParseError::new(loc, format!("unknown directive '{word}'")));
            }
        }
        Ok(())
    }

    /// The path of a file named in the current file: relative to that file's directory, or to the main file's.
    fn resolve(&self, name: &str) -> PathBuf {
        let dir = self.files.last().map_or_else(|| self.main_dir.clone(), |s| s.dir.clone());
        let rel = Path::new(name);
        let path = dir.join(rel);
        if !path.exists() && !rel.is_absolute() && *dir != *self.main_dir && self.main_dir.join(rel).exists() {
            // pbrt-v4 resolves relative to the main file's directory.
            return self.main_dir.join(rel);
        }
        path
    }

    fn open_file(&mut self, name: &str, loc: Loc, import: bool) -> Result<()> {
        let path = self.resolve(name);
        let canon = canonical(&path);
        if self.files.iter().any(|s| s.canonical == canon) {
            let chain: Vec<String> = self.files.iter().map(|s| s.lexer.file().display().to_string()).collect();
            return Err(ParseError::new(
                loc,
                format!(
                    "{} cycle: {} -> {}",
                    if import { "Import" } else { "Include" },
                    chain.join(" -> "),
                    path.display()
                ),
            ));
        }
        let text = read_text(&path, Some(&loc))?;
        self.scene.files.push(path.clone());
        let file: Arc<Path> = Arc::from(path.as_path());
        self.files.push(Source {
            lexer: Lexer::new(text, file),
            dir: dir_of(&path),
            canonical: canon,
            included_from: Some(loc),
            import: import.then(|| (self.gs.clone(), self.stack.len())),
        });
        Ok(())
    }

    /// Checks at the end of the input.
    fn finish(&mut self) -> Result<()> {
        if self.world_begin.is_none() {
            return Err(ParseError::new(self.last_loc.clone(), "end of input before WorldBegin"));
        }
        if let Some((_, kind, loc)) = self.stack.first() {
            let what = if *kind == Block::Object {
                "ObjectBegin without a matching ObjectEnd"
            } else {
                "AttributeBegin without a matching AttributeEnd"
            };
            return Err(ParseError::new(loc.clone(), what));
        }
        for (name, loc) in &self.named_material_uses {
            if !self.named_materials.contains_key(name) {
                return Err(ParseError::new(
                    loc.clone(),
                    format!("NamedMaterial '{name}' is never defined by MakeNamedMaterial"),
                ));
            }
        }
        for i in &self.scene.instances {
            if !self.objects.contains_key(&i.name) {
                return Err(ParseError::new(
                    i.loc.clone(),
                    format!("ObjectInstance '{}': no object of that name is defined", i.name),
                ));
            }
        }
        for (name, loc) in &self.medium_uses {
            if !self.media.contains_key(name) {
                return Err(ParseError::new(
                    loc.clone(),
                    format!("medium '{name}' is never defined by MakeNamedMedium"),
                ));
            }
        }
        for set in self.scene.param_sets() {
            for p in set.iter().filter(|p| p.ty == ParamType::Texture) {
                for t in &p.strings {
                    if !self.float_textures.contains_key(t) && !self.spectrum_textures.contains_key(t) {
                        return Err(ParseError::new(
                            p.loc.clone(),
                            format!("parameter 'texture {}': no texture named '{t}' is defined", p.name),
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}
