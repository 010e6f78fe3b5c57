//! `penumbra mrt level`: the level operators of a block layout (MRT thesis §3.5.3, §4.3,
//! §4.6), from a level file or a procedural level (`--maze`, `--corridor`, `--l-turn`).

use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use crate::fsutil::ensure_parent;
use anyhow::{Context, anyhow};
use clap::Args;
use penumbra_asset::AssetFile;
use penumbra_config::level::{LevelBlock, LevelConnection, LevelFile, load_level};
use penumbra_transport::level::{Block, Connection, Level, Links, corridor, l_turn, maze, parse_face};
use penumbra_transport::level_ops::{DEFAULT_MAX_DEPTH, DictOps, LevelBake, bake_level, to_asset_with_warps};
use penumbra_transport::shape::FACE_NAMES;
use penumbra_transport::warp::{LevelWarps, WarpMode, rebake_level};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Where a level comes from: a file or a procedural generator.
#[derive(Debug, Clone, Args)]
pub struct LevelSource {
    /// A random connected 2D maze of N blocks instead of a level file (thesis's large maze: 41).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub maze: Option<u32>,
    /// Seed of the maze.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// A straight corridor of N blocks instead of a level file.
    #[arg(long, value_parser = clap::value_parser!(u32).range(2..=4096))]
    pub corridor: Option<u32>,
    /// An L-turn with legs of N blocks (2N+1 blocks) instead of a level file.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=2048))]
    pub l_turn: Option<u32>,
}

/// `penumbra mrt level`.
#[derive(Debug, Args)]
pub struct MrtLevelArgs {
    /// Level file (TOML; schema: schemas/mrt-level.schema.json). Omit with --maze/--corridor/--l-turn.
    pub level: Option<PathBuf>,
    /// The dictionary (.mrtd, with interfaces).
    #[arg(long)]
    pub dict: PathBuf,
    /// Depth limit of the propagation: interfaces light may cross (§3.5.3; 0 = no light between blocks).
    #[arg(long, default_value_t = DEFAULT_MAX_DEPTH as u32, value_parser = clap::value_parser!(u32).range(0..=64))]
    pub max_depth: u32,
    /// Procedural level.
    #[command(flatten)]
    pub source: LevelSource,
    /// Also write the level as TOML (useful with --maze).
    #[arg(long)]
    pub write_level: Option<PathBuf>,
    /// Re-bake the block-local operators of every block whose stretch max(scale)/min(scale)
    /// exceeds S (e.g. 1.25; uniform scale is never re-baked), one re-bake per distinct
    /// (shape, warp) (docs/mrt.md, "Warps that stay accurate"). Writes MRTL kind version 2.
    #[command(flatten)]
    pub warps: WarpArgs,
    /// Output asset (.mrtl).
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// One JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The warp re-bake options of `mrt level` and `verify mrt`.
#[derive(Debug, Clone, Args)]
pub struct WarpArgs {
    /// Re-bake blocks whose stretch max(scale)/min(scale) exceeds S (S ≥ 1).
    #[arg(long, value_name = "S", value_parser = parse_stretch)]
    pub rebake_warps_above: Option<f64>,
    /// Gather rays per texel of a re-bake's F' (16..=1048576).
    #[arg(long, default_value_t = 4096, value_parser = clap::value_parser!(u32).range(16..=1_048_576))]
    pub warp_rays: u32,
    /// What a re-bake recomputes: stretched-prior (prior, F', enrichment, U_b', T_d→b') or
    /// retrace-u (U_b' = F' L_imp only).
    #[arg(long, default_value = "stretched-prior", value_parser = ["stretched-prior", "retrace-u"])]
    pub warp_mode: String,
}

fn parse_stretch(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("{s:?} is not a number"))?;
    if v >= 1.0 && v.is_finite() { Ok(v) } else { Err(format!("{v} is out of range (allowed: 1 <= S < inf)")) }
}

impl WarpArgs {
    /// The re-baked warps of `level` (`None` without `--rebake-warps-above`).
    pub fn rebake(&self, level: &Level, d: &DictOps) -> Result<Option<LevelWarps>, CliError> {
        let Some(s) = self.rebake_warps_above else { return Ok(None) };
        let mode = WarpMode::parse(&self.warp_mode).ok_or_else(|| CliError::input(anyhow!("bad --warp-mode")))?;
        let key = |v: &serde_json::Value| blake3::hash(v.to_string().as_bytes()).to_hex().to_string();
        rebake_level(level, d, s, self.warp_rays as usize, mode, &key, &|_| None)
            .map(Some)
            .map_err(|e| CliError::input(anyhow!("{e}")))
    }
}

/// A loaded dictionary (its operators for levels).
pub fn load_dict(path: &Path) -> Result<DictOps, CliError> {
    let f = AssetFile::open(path).with_context(|| format!("cannot open dictionary {}", path.display()))?;
    DictOps::from_asset(&f.asset()).map_err(|e| CliError::input(anyhow!("{}: {e}", path.display())))
}

/// The level file form of a level (for `--write-level` and the asset's meta).
pub fn to_file(level: &Level, names: &[String]) -> LevelFile {
    LevelFile {
        blocks: level
            .blocks
            .iter()
            .map(|b| LevelBlock {
                shape: names[b.shape].clone(),
                rotation: b.rotation,
                translation: b.translation,
                scale: (b.scale != [1.0; 3]).then_some(b.scale),
            })
            .collect(),
        connections: level
            .connections
            .iter()
            .map(|c| LevelConnection {
                a: c.a,
                a_face: FACE_NAMES[c.fa].into(),
                b: c.b,
                b_face: FACE_NAMES[c.fb].into(),
            })
            .collect(),
    }
}

/// The level of a level file, shapes resolved against the dictionary.
pub fn from_file(f: &LevelFile, names: &[String], path: &Path) -> Result<Level, CliError> {
    let err = |m: String| CliError::input(anyhow!("{}: {m}", path.display()));
    let mut blocks = Vec::with_capacity(f.blocks.len());
    for (i, b) in f.blocks.iter().enumerate() {
        let shape = names.iter().position(|n| *n == b.shape).ok_or_else(|| {
            err(format!("block {i}: shape {:?} is not in the dictionary (known: {})", b.shape, names.join(", ")))
        })?;
        blocks.push(Block {
            shape,
            rotation: b.rotation,
            translation: b.translation,
            scale: b.scale.unwrap_or([1.0; 3]),
        });
    }
    let mut connections = Vec::with_capacity(f.connections.len());
    for (i, c) in f.connections.iter().enumerate() {
        let face = |s: &str| {
            parse_face(s).ok_or_else(|| err(format!("connection {i}: face {s:?} is not one of -x, +x, -z, +z")))
        };
        connections.push(Connection { a: c.a, fa: face(&c.a_face)?, b: c.b, fb: face(&c.b_face)? });
    }
    Ok(Level { blocks, connections })
}

/// A parsed level file, resolved and validated against the dictionary (`path` names it in
/// errors).
pub fn validated(f: &LevelFile, path: &Path, d: &DictOps) -> Result<(Level, Links), CliError> {
    let level = from_file(f, &d.names, path)?;
    let links =
        level.validate(&d.names, &d.missing).map_err(|e| CliError::input(anyhow!("{}: {e}", path.display())))?;
    Ok((level, links))
}

/// Resolves the level (file or procedural) and validates it against the dictionary.
pub fn resolve(file: Option<&Path>, src: &LevelSource, d: &DictOps) -> Result<(Level, Links, String), CliError> {
    let procedural = [src.maze.is_some(), src.corridor.is_some(), src.l_turn.is_some()].iter().filter(|&&x| x).count();
    if procedural + usize::from(file.is_some()) != 1 {
        return Err(CliError::input(anyhow!("give exactly one of: a level file, --maze N, --corridor N, --l-turn N")));
    }
    let (level, what, path) = if let Some(p) = file {
        let f = load_level(p)?;
        (from_file(&f, &d.names, p)?, p.display().to_string(), p.to_path_buf())
    } else {
        let gen_err = |e: penumbra_transport::level::LevelError| CliError::input(anyhow!("procedural level: {e}"));
        if let Some(n) = src.maze {
            (
                maze(n as usize, src.seed, &d.missing).map_err(gen_err)?,
                format!("maze {n} seed {}", src.seed),
                PathBuf::from("--maze"),
            )
        } else if let Some(n) = src.corridor {
            (corridor(n as usize, &d.missing).map_err(gen_err)?, format!("corridor {n}"), PathBuf::from("--corridor"))
        } else {
            let n = src.l_turn.unwrap_or(1) as usize;
            (l_turn(n, n, &d.missing).map_err(gen_err)?, format!("l-turn {n}"), PathBuf::from("--l-turn"))
        }
    };
    let links =
        level.validate(&d.names, &d.missing).map_err(|e| CliError::input(anyhow!("{}: {e}", path.display())))?;
    Ok((level, links, what))
}

/// Bakes a level's operators; returns the bake and the asset bytes. `key` is the cache key
/// recorded in `meta` (default: a hash of the level, the dictionary and the depth).
pub fn bake(
    level: &Level,
    links: &Links,
    d: &DictOps,
    max_depth: usize,
    key: Option<String>,
) -> Result<(LevelBake, Vec<u8>), CliError> {
    bake_with_warps(level, links, d, max_depth, key, None)
}

/// [`bake`] with re-baked warps; with no warp entry (no block beyond the threshold) the
/// bytes of [`bake`].
pub fn bake_with_warps(
    level: &Level,
    links: &Links,
    d: &DictOps,
    max_depth: usize,
    key: Option<String>,
    warps: Option<&LevelWarps>,
) -> Result<(LevelBake, Vec<u8>), CliError> {
    let b = bake_level(level, links, d, max_depth).map_err(|e| CliError::input(anyhow!("{e}")))?;
    let lf = serde_json::to_value(to_file(level, &d.names)).map_err(CliError::internal)?;
    let warps = warps.filter(|w| !w.entries.is_empty());
    let key = key.unwrap_or_else(|| {
        let mut k = json!({"tool": env!("CARGO_PKG_VERSION"), "stage": "mrt_level", "level": lf, "dict": d.crc32c, "max_depth": max_depth});
        if let Some(w) = warps {
            k["warps"] = w.meta();
        }
        blake3::hash(k.to_string().as_bytes()).to_hex().to_string()
    });
    let asset = to_asset_with_warps(level, links, d, &b, lf, Some(&key), warps).map_err(CliError::internal)?;
    let bytes = asset.to_bytes().map_err(CliError::internal)?;
    Ok((b, bytes))
}

/// Runs `penumbra mrt level`.
#[allow(clippy::print_stderr)]
pub fn run(a: &MrtLevelArgs) -> Result<ExitCode, CliError> {
    let start = Instant::now();
    let d = load_dict(&a.dict)?;
    let (level, links, what) = resolve(a.level.as_deref(), &a.source, &d)?;
    if let Some(w) = &a.write_level {
        ensure_parent(w)?;
        crate::fsutil::write_atomic_text(w, &to_file(&level, &d.names).to_toml())
            .with_context(|| format!("cannot write {}", w.display()))?;
    }
    let warps = a.warps.rebake(&level, &d)?;
    let (b, bytes) = bake_with_warps(&level, &links, &d, a.max_depth as usize, None, warps.as_ref())?;
    ensure_parent(&a.output)?;
    penumbra_asset::write_file_atomic(&a.output, &bytes)
        .with_context(|| format!("cannot write {}", a.output.display()))?;
    let seconds = start.elapsed().as_secs_f64();
    let mut v = serde_json::to_value(&b.metrics).map_err(CliError::internal)?;
    if let Some(o) = v.as_object_mut() {
        o.insert("level".into(), json!(what));
        o.insert("atlas".into(), json!([b.atlas.width, b.atlas.height]));
        o.insert("bytes".into(), json!(bytes.len()));
        o.insert("seconds".into(), json!(seconds));
        o.insert("output".into(), json!(a.output.display().to_string()));
        if let Some(w) = &warps {
            o.insert("warps".into(), warp_report(w));
        }
    }
    if a.json {
        print_json(&v);
    } else {
        eprintln!(
            "wrote {} ({} bytes) in {:.3} s: {} ({} blocks), {} block pairs, {} records, depth ≤ {}, atlas {}×{}",
            a.output.display(),
            bytes.len(),
            seconds,
            what,
            b.metrics.blocks,
            b.metrics.block_pairs,
            b.metrics.records,
            a.max_depth,
            b.atlas.width,
            b.atlas.height
        );
    }
    Ok(ExitCode::Ok)
}

/// The `--json` report of re-baked warps: each distinct (shape, warp) with its seconds.
pub fn warp_report(w: &LevelWarps) -> serde_json::Value {
    json!({
        "rebake_above": w.threshold,
        "mode": w.mode.name(),
        "rays": w.rays,
        "distinct": w.entries.len(),
        "blocks_rebaked": w.block_warp.iter().filter(|x| x.is_some()).count(),
        "entries": w.entries.iter().map(|e| json!({
            "shape": e.shape, "warp": e.warp, "cache_key": e.cache_key, "seconds": e.seconds,
        })).collect::<Vec<_>>(),
        "seconds_per_warp": if w.entries.is_empty() { 0.0 } else {
            w.entries.iter().map(|e| e.seconds).sum::<f64>() / w.entries.len() as f64
        },
    })
}
