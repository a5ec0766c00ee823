//! `prismatic merge`: the parts of a sharded render (`prismatic render --shard K/N`) into the image one process
//! would have rendered.
//!
//! Every part stores its film's unnormalised sums exactly (see [`film::write_part`]) with its shard, pass range,
//! seed, scene hash and options hash. The merge checks that the parts are the N shards of one render (same
//! scene files, seed and options; every shard once, each complete), reads the scene again for the film's
//! definition (colour space, sensor, buckets; the scene files must still hash the same), then:
//!
//! - **sample shards** (every integrator but `sppm`): the sums of the parts are added in shard order, that is in
//!   pass order. One process adds the same samples one by one; the merge adds the same per-part sums, so a sum of
//!   n terms is regrouped at N − 1 places: the two differ by at most 2·(n − 1)·2⁻⁵³ of the sum of the terms'
//!   magnitudes (standard error bound of recursive summation). For camera-sample sums of non-negative radiance
//!   with the default filters' positive weights this is 2·spp·2⁻⁵³ relative (2⁻²⁹ at 16 million spp), below the
//!   rounding of the f32 written, so a written value differs from the single-process render by at most one unit
//!   in the last place of f32 (and is mostly bit-identical). Filters with negative lobes (Mitchell, Lanczos)
//!   scale the bound by Σ|w| / |Σw|.
//! - **sppm shards** are bands of rows rendered with all iterations: their pixels are pasted, bit for bit the
//!   pixels of the whole render.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use film::FilmState;

use crate::checkpoint::Plan;
use crate::render_cmd::{split, Setup};

/// Arguments of `prismatic merge`.
#[derive(Args, Debug)]
#[command(
    after_help = "Example:\n  for k in 1 2 3 4; do prismatic render scene.pbrt --spp 1024 --shard $k/4 -o part-$k.exr; done\n  \
                        prismatic merge part-*.exr -o image.exr\n\n\
                        The parts must be the N shards of one render: the same scene files, seed and options, every \
                        shard once and complete (an interrupted shard is refused). The scene is read again (from \
                        the path the parts record, or --scene) for the film's colour space, sensor and buckets; \
                        its files must still be those rendered. Sample shards add up to the single-process image \
                        to within one unit in the last place of f32 (see the README); sppm shards, which are \
                        bands of rows, paste bit for bit."
)]
pub struct MergeArgs {
    /// The parts (EXR files written by `prismatic render --shard K/N`), in any order.
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,

    /// The merged image (.exr, .png or .pfm).
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,

    /// The scene file, if it is no longer where the parts say it was rendered from.
    #[arg(long, value_name = "FILE")]
    pub scene: Option<PathBuf>,

    /// Print nothing on success.
    #[arg(long)]
    pub quiet: bool,
}

/// One part: its file, header and sums.
struct Part {
    path: PathBuf,
    attrs: BTreeMap<String, String>,
    state: FilmState,
    shard: (u32, u32),
    passes: (u32, u32),
}

impl Part {
    fn read(path: &Path) -> Result<Self> {
        let (attrs, state) = film::read_part(path)?;
        if attrs.get("prismatic.part").map(String::as_str) != Some("1") {
            bail!("{}: not a part of a sharded render (no prismatic.part attribute)", path.display());
        }
        let get = |k: &str| attrs.get(k).ok_or_else(|| anyhow!("{}: no '{k}' attribute", path.display()));
        let shard = crate::checkpoint::parse_shard(get("prismatic.shard")?)?;
        let passes = get("prismatic.passes")?
            .split_once("..")
            .and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?)))
            .ok_or_else(|| anyhow!("{}: malformed prismatic.passes", path.display()))?;
        Ok(Part { path: path.to_path_buf(), attrs, state, shard, passes })
    }

    fn attr(&self, k: &str) -> &str {
        self.attrs.get(k).map_or("", String::as_str)
    }

    /// The render options recorded in the part.
    fn plan(&self) -> Result<Plan> {
        let pairs: BTreeMap<String, String> = self
            .attrs
            .iter()
            .filter_map(|(k, v)| k.strip_prefix("prismatic.plan.").map(|k| (k.to_string(), v.clone())))
            .collect();
        Plan::from_pairs(&pairs).with_context(|| format!("{}", self.path.display()))
    }
}

/// Runs the subcommand; returns the summary to print.
pub fn run(args: &MergeArgs) -> Result<String> {
    film::ImageFormat::from_path(&args.output)?;
    let mut parts = args.parts.iter().map(|p| Part::read(p)).collect::<Result<Vec<_>>>()?;
    parts.sort_by_key(|p| p.shard.0);
    let first = &parts[0];
    // The same render: scene, options, seed, shard count, unit, passes.
    for key in [
        "prismatic.sceneHash",
        "prismatic.seed",
        "prismatic.optionsHash",
        "prismatic.unit",
        "prismatic.passesTotal",
        "prismatic.bounds",
    ] {
        if let Some(p) = parts.iter().find(|p| p.attr(key) != first.attr(key)) {
            let what = match key {
                "prismatic.sceneHash" => "are parts of different scenes (or of scene files changed in between)",
                "prismatic.optionsHash" => "are parts of renders with different options",
                "prismatic.seed" => "are parts of renders with different seeds",
                _ => "are parts of different renders",
            };
            bail!(
                "{} and {} {what} ({key} {} vs {})",
                first.path.display(),
                p.path.display(),
                first.attr(key),
                p.attr(key)
            );
        }
    }
    let n = first.shard.1;
    if let Some(p) = parts.iter().find(|p| p.shard.1 != n) {
        bail!("{} is a shard of {n} parts, {} of {}", first.path.display(), p.path.display(), p.shard.1);
    }
    for w in parts.windows(2) {
        if w[0].shard.0 == w[1].shard.0 {
            bail!(
                "shard {}/{n} is given twice ({} and {}): their samples overlap",
                w[0].shard.0,
                w[0].path.display(),
                w[1].path.display()
            );
        }
    }
    let missing: Vec<String> =
        (1..=n).filter(|k| !parts.iter().any(|p| p.shard.0 == *k)).map(|k| format!("{k}/{n}")).collect();
    if !missing.is_empty() {
        bail!("shards {} are missing (every one of the {n} parts is needed)", missing.join(", "));
    }

    // The film: the scene read again with the recorded options, checked against the parts' hashes.
    let mut plan = first.plan()?;
    plan.shard = None;
    if let Some(scene) = &args.scene {
        plan.scene = scene.clone();
    }
    if !plan.scene.exists() {
        let message = format!(
            "the scene {} the parts were rendered from is not there; name it with --scene",
            plan.scene.display()
        );
        return Err(crate::exit::io_error(std::io::ErrorKind::NotFound, message));
    }
    plan.output = Some(args.output.clone());
    let setup = Setup::new(&plan)?;
    if format!("{:016x}", setup.scene_hash) != first.attr("prismatic.sceneHash") {
        bail!(
            "the scene files of {} are not those the parts were rendered from (scene hash differs)",
            plan.scene.display()
        );
    }
    if format!("{:016x}", setup.options_hash) != first.attr("prismatic.optionsHash") {
        bail!("the scene {} with the recorded options is not the render the parts come from", plan.scene.display());
    }
    let mut film = film::Film::new(setup.spec.clone())?;
    let total = setup.total;
    let sppm = first.attr("prismatic.unit") == render::PassUnit::Iterations.name();
    for part in &parts {
        // Each shard complete: its passes are those `render --shard` gives it (for sppm: all of them).
        let (k, _) = part.shard;
        let expected = if sppm { 0..total } else { split(total, part.shard) };
        if part.passes != (expected.start, expected.end) {
            bail!(
                "{} holds passes {}..{} of shard {k}/{n}, which has {}..{} (an interrupted shard? render it again)",
                part.path.display(),
                part.passes.0,
                part.passes.1,
                expected.start,
                expected.end
            );
        }
    }
    for (i, part) in parts.iter().enumerate() {
        let r = if sppm {
            let rows = split(setup.whole.height(), part.shard);
            let (y0, y1) = (setup.whole.y0 + rows.start, setup.whole.y0 + rows.end);
            let b = part.state.bounds;
            if (b.x0, b.x1, b.y0, b.y1) != (setup.whole.x0, setup.whole.x1, y0, y1) {
                bail!("{} holds pixels {b:?}, not the rows {y0}..{y1} of its shard", part.path.display());
            }
            film.paste(&part.state)
        } else if i == 0 {
            film.paste(&part.state)
        } else {
            film.add_state(&part.state)
        };
        r.with_context(|| format!("{}", part.path.display()))?;
    }
    let header = vec![
        ("samplesPerPixel".to_string(), total.to_string()),
        ("samplesPerPixelRequested".to_string(), total.to_string()),
        ("mergedParts".to_string(), n.to_string()),
    ];
    film::write_image_with(&film, &args.output, &header)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    if args.quiet {
        return Ok(String::new());
    }
    Ok(format!(
        "wrote {} ({} parts, {total} {}, {})\n",
        args.output.display(),
        n,
        setup.built.integrator.needs().unit.name(),
        setup.built.integrator.name()
    ))
}
