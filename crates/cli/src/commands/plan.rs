//! `penumbra plan <scene.gltf|glb> -o bake.toml`: the bake config a glTF level needs.
//!
//! Every node gets a role from `--role ROLE=GLOB` (on node names; the first matching option
//! wins, and options win over the file) or from its `extras`
//! (`{"penumbra": {"role": "occluder" | "character" | "clutter" | "block", …}}`); a node
//! without one inherits its nearest ancestor's. Roles map to stages:
//! - `character` → a `[[spheres]]` entry (with skin weights when the node's mesh is skinned;
//!   otherwise a plain set, and a note says so), plus `[tables]` for the runtime;
//! - `occluder` → a `[[fiv]]` entry (a skinned occluder deforms, which a FIV table cannot
//!   follow: it gets a skinned `[[spheres]]` entry instead, with a note);
//! - `clutter` → an entry of the DRT clutter file (`<stem>.clutter.toml`, the mesh in place)
//!   and the `[drt]` stage;
//! - `block` → a block of the MRT level file (`<stem>.level.toml`: the node's world box, its
//!   openings read from the geometry or given as `shape`/`rotation` in the extras, connections
//!   where two openings coincide), the `[mrt]` dictionary and the `[mrt_level]` stage.
//!
//! Stages select their triangles with `node = "<name>"` (a node and its descendants). Nodes
//! with triangles but no role, or a role this tool does not know, are listed as unassigned,
//! never guessed. Nothing is written unless the whole plan succeeds (each file atomically).

use super::plan_level;
use crate::commands::print_json;
use crate::exit::{CliError, ExitCode};
use crate::fsutil::{ensure_parent, write_atomic_text};
use anyhow::anyhow;
use clap::{Args, ValueEnum};
use penumbra_config::clutter::{ClutterEntry, ClutterFile};
use penumbra_config::level::LevelFile;
use penumbra_config::{BakeConfig, DrtStage, FivStage, MrtLevelStage, MrtStage, NodeSelect, SpheresStage, TablesStage};
use penumbra_geometry::scene::{Scene, glob_match};
use serde_json::{Value, json};
use std::path::{Component, Path, PathBuf};

/// A node's role in the bake.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Role {
    /// A rigid shadow caster: FIV occlusion textures.
    Occluder,
    /// A (usually skinned) character: a sphere set.
    Character,
    /// A prop inside the level's blocks: DRT clutter operators.
    Clutter,
    /// A room of the level: an MRT block.
    Block,
}

/// The role names, in the order messages list them.
pub const ROLE_NAMES: [&str; 4] = ["occluder", "character", "clutter", "block"];

impl Role {
    /// The role called `s`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "occluder" => Some(Self::Occluder),
            "character" => Some(Self::Character),
            "clutter" => Some(Self::Clutter),
            "block" => Some(Self::Block),
            _ => None,
        }
    }

    /// The role's name.
    pub fn name(self) -> &'static str {
        ROLE_NAMES[self as usize]
    }
}

/// `--role ROLE=GLOB`.
fn parse_role(s: &str) -> Result<(Role, String), String> {
    let bad = |why: &str| format!("{s:?}: {why} (expected ROLE=GLOB, ROLE one of {})", ROLE_NAMES.join(", "));
    let (r, g) = s.split_once('=').ok_or_else(|| bad("no `=`"))?;
    let role = Role::parse(r.trim()).ok_or_else(|| bad(&format!("unknown role {:?}", r.trim())))?;
    if g.is_empty() {
        return Err(bad("empty name pattern"));
    }
    Ok((role, g.to_string()))
}

/// Quality presets (Godot-like: `preview` bakes in seconds, `final` at the papers' settings).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Preset {
    /// The demo's settings: small dictionary, 32 spheres, FIV Table 1's smallest grid.
    Preview,
    /// The papers' settings: thesis dictionary, SH order 6 with 32 polished spheres, a finer FIV
    /// grid, DRT at 16² texels and 1024 rays.
    Final,
}

/// The knobs a preset sets.
#[derive(Debug, Clone)]
pub struct PresetKnobs {
    /// `[tables]`.
    pub tables: TablesStage,
    /// Spheres per character.
    pub sphere_count: u32,
    /// `polish` of sphere entries.
    pub polish: bool,
    /// FIV samples.
    pub fiv_samples: [u32; 3],
    /// `[mrt]`.
    pub mrt: MrtStage,
    /// `[drt]` texels per box-face edge and rays.
    pub drt_res_rays: (u32, u32),
}

fn mrt_stage(face_res: Option<u32>, kd: Option<u32>, kb: Option<u32>, rays: Option<u32>) -> MrtStage {
    MrtStage {
        dictionary: Some("cube2d".into()),
        face_res,
        kd,
        kb,
        rays,
        albedo: None,
        enrich: None,
        fallback_modes: None,
        gather: None,
        balance: None,
        exclude_same_face: None,
        light_layout: None,
        light_radius: None,
        vector_rays: None,
        volume_res: None,
        probe_rays: None,
        test_lights: None,
        reference_rays: None,
        seed: None,
        interfaces: None,
        k_rlf: None,
        k_r: None,
        lf_spatial: None,
        lf_dir: None,
        lf_super: None,
        interface_enrich: None,
        response_rays: None,
        interface_vectors: None,
        level_shapes_only: None,
        output: None,
    }
}

impl Preset {
    /// The knobs (the same values as `bake-configs/preview.toml` and `final.toml`).
    pub fn knobs(self) -> PresetKnobs {
        let tables = |order, theta| TablesStage {
            order,
            theta_samples: Some(theta),
            shading_tolerance: None,
            env: None,
            output: None,
        };
        match self {
            Preset::Preview => {
                let mut mrt = mrt_stage(Some(8), Some(32), Some(16), Some(2048));
                mrt.vector_rays = Some(256);
                mrt.probe_rays = Some(1024);
                mrt.reference_rays = Some(256);
                mrt.lf_spatial = Some(6);
                mrt.lf_dir = Some(8);
                mrt.lf_super = Some(2);
                mrt.k_rlf = Some(48);
                mrt.k_r = Some(16);
                mrt.response_rays = Some(256);
                PresetKnobs {
                    tables: tables(4, 256),
                    sphere_count: 32,
                    polish: false,
                    fiv_samples: [32, 17, 15],
                    mrt,
                    drt_res_rays: (8, 256),
                }
            }
            // the `penumbra mrt dict` defaults are the thesis settings
            Preset::Final => PresetKnobs {
                // order 6 and 32 spheres: more spheres shade worse at low SH order (docs/shadows.md)
                tables: tables(6, 512),
                sphere_count: 32,
                polish: true,
                fiv_samples: [64, 33, 30],
                mrt: mrt_stage(Some(16), Some(64), Some(32), Some(16384)),
                drt_res_rays: (16, 1024),
            },
        }
    }
}

/// `penumbra plan`.
#[derive(Debug, Args)]
pub struct PlanArgs {
    /// The glTF level (.gltf or .glb).
    pub scene: PathBuf,
    /// The bake config to write (TOML). The DRT clutter file and the MRT level file, when the
    /// scene needs them, go beside it as `<stem>.clutter.toml` and `<stem>.level.toml`.
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// ROLE=GLOB: nodes whose name matches GLOB (`*` any run, `?` one character) get ROLE
    /// (occluder, character, clutter, block). Repeatable; the first match wins; overrides the
    /// file's `extras.penumbra.role`.
    #[arg(long = "role", value_name = "ROLE=GLOB", value_parser = parse_role)]
    pub roles: Vec<(Role, String)>,
    /// Quality preset of the stage knobs.
    #[arg(long, value_enum, default_value_t = Preset::Preview)]
    pub preset: Preset,
    /// Environment of the FIV stages: a lat-long .exr/.hdr or `builtin:area-lights`.
    #[arg(long, default_value = "builtin:area-lights")]
    pub env: String,
    /// The config's `output_dir` (relative to the config; default: the config's file stem, so
    /// `-o out/level.toml` bakes into `out/level/`).
    #[arg(long)]
    pub output_dir: Option<String>,
    /// One JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// A role as the file states it.
#[derive(Debug, Clone, PartialEq)]
enum Stated {
    Known(Role, &'static str),
    Unknown(String),
}

/// `extras.penumbra` of a node, if any (invalid JSON is the caller's error).
fn penumbra_extras(extras: Option<&str>) -> Result<Option<Value>, String> {
    let Some(text) = extras else { return Ok(None) };
    let v: Value = serde_json::from_str(text).map_err(|e| format!("extras are not JSON: {e}"))?;
    Ok(v.get("penumbra").cloned())
}

/// One stage entry the plan makes: a named node with a role, and the nodes it stands for.
#[derive(Debug)]
struct Entry {
    node: usize,
    name: String,
    role: Role,
    source: &'static str,
    /// This node and the descendants that take its role (for geometry and skinning).
    members: Vec<usize>,
}

/// A file-name-safe form of a node name.
fn file_stem(name: &str) -> String {
    let s: String =
        name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect();
    if s.is_empty() { "node".into() } else { s }
}

/// `target` relative to directory `base` (both made absolute against the working directory).
fn relative_to(target: &Path, base: &Path) -> Result<String, CliError> {
    let abs = |p: &Path| -> Result<PathBuf, CliError> {
        let p = if p.is_absolute() { p.to_path_buf() } else { std::env::current_dir()?.join(p) };
        // lexical normalisation (the base directory may not exist yet)
        let mut out = PathBuf::new();
        for c in p.components() {
            match c {
                Component::ParentDir => {
                    out.pop();
                }
                Component::CurDir => {}
                other => out.push(other),
            }
        }
        Ok(out)
    };
    let (t, b) = (abs(target)?, abs(base)?);
    let (tc, bc): (Vec<_>, Vec<_>) = (t.components().collect(), b.components().collect());
    let common = tc.iter().zip(&bc).take_while(|(a, b)| a == b).count();
    let mut rel = PathBuf::new();
    for _ in common..bc.len() {
        rel.push("..");
    }
    for c in &tc[common..] {
        rel.push(c);
    }
    let s = rel.to_string_lossy().replace('\\', "/");
    Ok(if s.is_empty() { ".".into() } else { s })
}

/// What `plan` decided: the files' contents and the report.
struct Plan {
    config: BakeConfig,
    level: Option<LevelFile>,
    clutter: Option<ClutterFile>,
    report: Value,
    notes: Vec<String>,
    unassigned: Vec<Value>,
}

/// Loads the scene (exit 2 naming the file when it is missing or not glTF).
fn load_scene(path: &Path) -> Result<Scene, CliError> {
    if !path.is_file() {
        return Err(CliError::input(anyhow!("scene {} does not exist", path.display())));
    }
    match penumbra_geometry::import::mesh_format(path) {
        Ok(penumbra_geometry::import::MeshFormat::Gltf) => {}
        _ => {
            return Err(CliError::input(anyhow!(
                "scene {}: not a glTF file (expected .gltf or .glb; roles live in glTF node names and extras)",
                path.display()
            )));
        }
    }
    let (scene, _) = penumbra_geometry::load_mesh(path).map_err(|e| CliError::input(anyhow!("scene {e}")))?;
    Ok(scene)
}

/// The roles of a scene's nodes: the stage entries, the unassigned nodes and what was noticed.
struct Assignment {
    entries: Vec<Entry>,
    unassigned: Vec<Value>,
    notes: Vec<String>,
    /// `extras.penumbra` per node.
    extras: Vec<Option<Value>>,
    /// Per node: whether any of its vertices is skinned.
    skinned: Vec<bool>,
    /// The node of each triangle of the scene mesh.
    node_of_tri: Vec<Option<usize>>,
}

/// Gives every node its role (see the module docs).
fn assign(a: &PlanArgs, scene: &Scene) -> Result<Assignment, CliError> {
    let n = scene.nodes.len();
    let mut notes: Vec<String> = Vec::new();
    let label = |i: usize| scene.nodes[i].name.clone().unwrap_or_else(|| format!("(node {i}, unnamed)"));
    // triangles per node, skinned nodes
    let node_of_tri: Vec<Option<usize>> = scene
        .mesh
        .indices
        .iter()
        .map(|t| scene.bindings.get(t[0] as usize).and_then(|b| b.node).map(|n| n as usize))
        .collect();
    let mut tris = vec![0usize; n];
    for x in node_of_tri.iter().flatten() {
        if *x < n {
            tris[*x] += 1;
        }
    }
    let mut skinned = vec![false; n];
    for b in &scene.bindings {
        if let (Some(nd), Some(_)) = (b.node, b.skin) {
            if let Some(s) = skinned.get_mut(nd as usize) {
                *s = true;
            }
        }
    }
    // stated roles: --role first, then extras
    let mut extras: Vec<Option<Value>> = Vec::with_capacity(n);
    let mut stated: Vec<Option<Stated>> = Vec::with_capacity(n);
    for (i, node) in scene.nodes.iter().enumerate() {
        let ex = penumbra_extras(node.extras.as_deref())
            .map_err(|e| CliError::input(anyhow!("{}: node {:?}: {e}", a.scene.display(), label(i))))?;
        let from_flag =
            node.name.as_deref().and_then(|nm| a.roles.iter().find(|(_, g)| glob_match(g, nm))).map(|(r, _)| *r);
        let s = match (from_flag, ex.as_ref().and_then(|e| e.get("role"))) {
            (Some(r), _) => Some(Stated::Known(r, "--role")),
            (None, Some(Value::String(r))) => Some(match Role::parse(r) {
                Some(role) => Stated::Known(role, "extras"),
                None => Stated::Unknown(r.clone()),
            }),
            (None, Some(other)) => Some(Stated::Unknown(other.to_string())),
            (None, None) => None,
        };
        extras.push(ex);
        stated.push(s);
    }
    for (r, g) in &a.roles {
        if !scene.nodes.iter().any(|nd| nd.name.as_deref().is_some_and(|nm| glob_match(g, nm))) {
            notes.push(format!("--role {}={g}: no node name matches", r.name()));
        }
    }
    // nearest node (self or ancestor) with a stated role
    let owner = |mut i: usize| -> Option<usize> {
        for _ in 0..=n {
            if stated[i].is_some() {
                return Some(i);
            }
            i = scene.nodes[i].parent?;
        }
        None
    };
    let parent_owner = |i: usize| scene.nodes[i].parent.and_then(owner);
    // entries: nodes with a known stated role not already covered by an ancestor of that role
    let mut entries: Vec<Entry> = Vec::new();
    for i in 0..n {
        let Some(Stated::Known(role, source)) = stated[i].clone() else { continue };
        let up = parent_owner(i);
        if let Some(u) = up {
            match &stated[u] {
                Some(Stated::Known(r, _)) if *r == role => continue,
                Some(Stated::Known(r, _)) if *r != Role::Block => notes.push(format!(
                    "node {:?} ({}) lies under {:?} ({}): that stage's node selection also takes its triangles",
                    label(i),
                    role.name(),
                    label(u),
                    r.name()
                )),
                _ => {}
            }
        }
        // the nodes that take i's role: i and the descendants whose nearest node with another
        // stated role is not below i
        let members: Vec<usize> = (0..n)
            .filter(|&m| {
                let mut k = m;
                for _ in 0..=n {
                    if k == i {
                        return true;
                    }
                    match &stated[k] {
                        Some(Stated::Known(r, _)) if *r == role => {}
                        Some(_) => return false,
                        None => {}
                    }
                    match scene.nodes[k].parent {
                        Some(p) => k = p,
                        None => return false,
                    }
                }
                false
            })
            .collect();
        let Some(name) = scene.nodes[i].name.clone() else {
            notes.push(format!("{} has role {} but no name: stages select nodes by name", label(i), role.name()));
            continue;
        };
        if name.contains(['*', '?']) {
            notes
                .push(format!("node {name:?}: `*`/`?` in the name also select other nodes that match it as a pattern"));
        }
        if members.iter().all(|&m| tris[m] == 0) {
            notes.push(format!("node {name:?} ({}) has no triangles: no stage", role.name()));
            continue;
        }
        // nodes of the same name are selected together: one entry
        if let Some(e) = entries.iter_mut().find(|e| e.name == name) {
            if e.role != role {
                return Err(CliError::input(anyhow!(
                    "{}: two nodes named {name:?} have roles {} and {}: stages select nodes by name",
                    a.scene.display(),
                    e.role.name(),
                    role.name()
                )));
            }
            e.members.extend(members);
            continue;
        }
        entries.push(Entry { node: i, name, role, source, members });
    }
    // unassigned: nodes with triangles and no known role
    let mut unassigned = Vec::new();
    for i in (0..n).filter(|&i| tris[i] > 0) {
        let reason = match owner(i).and_then(|o| stated[o].clone().map(|s| (o, s))) {
            None => "no role".to_string(),
            Some((o, Stated::Unknown(r))) => {
                if o == i {
                    format!("unknown role {r} (known: {})", ROLE_NAMES.join(", "))
                } else {
                    format!("ancestor {:?} has unknown role {r}", label(o))
                }
            }
            Some((o, Stated::Known(..))) => {
                if entries.iter().any(|e| e.members.contains(&i)) {
                    continue;
                }
                format!("its role comes from {:?}, which has no name to select it by", label(o))
            }
        };
        unassigned.push(json!({"node": scene.nodes[i].name, "index": i, "triangles": tris[i],
                               "skinned": skinned[i], "reason": reason}));
    }
    Ok(Assignment { entries, unassigned, notes, extras, skinned, node_of_tri })
}

/// Makes the plan (no file is written here).
fn make_plan(a: &PlanArgs, scene: &Scene) -> Result<Plan, CliError> {
    let Assignment { entries, unassigned, mut notes, extras, skinned, node_of_tri } = assign(a, scene)?;
    let dir = a.output.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let mesh = relative_to(&a.scene, dir)?;
    let stem = a.output.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "bake".into());
    let env = if a.env.starts_with("builtin:") {
        a.env.clone()
    } else {
        if !Path::new(&a.env).is_file() {
            return Err(CliError::input(anyhow!("--env {}: file does not exist", a.env)));
        }
        relative_to(Path::new(&a.env), dir)?
    };
    let k = a.preset.knobs();
    let mut used_names: Vec<String> = Vec::new();
    let mut unique = |base: String, ext: &str| {
        let mut s = format!("{base}.{ext}");
        let mut c = 2;
        while used_names.contains(&s) {
            s = format!("{base}-{c}.{ext}");
            c += 1;
        }
        used_names.push(s.clone());
        s
    };
    let mut spheres = Vec::new();
    let mut fiv = Vec::new();
    let mut clutter = Vec::new();
    let mut blocks: Vec<plan_level::PlannedBlock> = Vec::new();
    let mut report_entries = Vec::new();
    for e in &entries {
        let is_skinned = e.members.iter().any(|&m| skinned[m]);
        let sphere_entry = |output: String| SpheresStage {
            mesh: mesh.clone(),
            count: Some(k.sphere_count),
            target_error: None,
            target_union: None,
            max_count: None,
            method: None,
            grid: None,
            iterations: None,
            seed: None,
            hierarchy: Some(true),
            skin: is_skinned.then_some(true),
            polish: k.polish.then_some(true),
            skin_padding: is_skinned.then_some(true),
            albedo: None,
            mesh_name: None,
            node: Some(NodeSelect::One(e.name.clone())),
            output: Some(output),
        };
        let stage = match (e.role, is_skinned) {
            (Role::Character, _) => {
                if !is_skinned {
                    notes.push(format!("character {:?} is not skinned: a plain (rigid) sphere set", e.name));
                }
                spheres.push(sphere_entry(unique(file_stem(&e.name), "sphr")));
                "spheres"
            }
            (Role::Occluder, true) => {
                notes.push(format!(
                    "occluder {:?} is skinned: FIV tables cannot follow a deforming mesh, so it gets a skinned sphere set",
                    e.name
                ));
                spheres.push(sphere_entry(unique(file_stem(&e.name), "sphr")));
                "spheres"
            }
            (Role::Occluder, false) => {
                fiv.push(FivStage {
                    mesh: mesh.clone(),
                    node: Some(NodeSelect::One(e.name.clone())),
                    env: env.clone(),
                    env_rotate: None,
                    samples: Some(k.fiv_samples),
                    r_min: None,
                    r_max: None,
                    up: None,
                    cube_size: None,
                    irradiance_size: None,
                    half: None,
                    target: None,
                    gate: None,
                    output: Some(unique(file_stem(&e.name), "fivt")),
                });
                "fiv"
            }
            (Role::Clutter, _) => {
                if is_skinned {
                    notes.push(format!("clutter {:?} is skinned: DRT takes it at its rest pose", e.name));
                }
                clutter.push(ClutterEntry {
                    name: Some(e.name.clone()),
                    mesh: Some(mesh.clone()),
                    node: Some(NodeSelect::One(e.name.clone())),
                    charts: None,
                    lightmap_res: None,
                    box_: None,
                    translate: [0.0; 3],
                    rotate_y_deg: None,
                    rotate: None,
                    scale: None,
                    albedo: None,
                });
                "drt"
            }
            (Role::Block, _) => {
                let Some(g) = plan_level::geometry(scene, &node_of_tri, &e.members) else { continue };
                blocks.push(plan_level::block(&a.scene, &e.name, extras[e.node].as_ref(), g)?);
                "mrt_level"
            }
        };
        report_entries.push(json!({"node": e.name, "role": e.role.name(), "source": e.source,
                                   "skinned": is_skinned, "stage": stage}));
    }
    let level = if blocks.is_empty() {
        None
    } else {
        let (l, level_notes) = plan_level::level(&a.scene, &blocks)?;
        notes.extend(level_notes);
        Some(l)
    };
    // clutter needs a level; check each piece lies in a block
    let clutter_file = if clutter.is_empty() {
        None
    } else if blocks.is_empty() {
        notes.push(format!(
            "clutter {} needs a level (nodes with role block) for DRT: no [drt] stage",
            clutter.iter().filter_map(|c| c.name.clone()).map(|s| format!("{s:?}")).collect::<Vec<_>>().join(", ")
        ));
        for r in report_entries.iter_mut().filter(|r| r["stage"] == "drt") {
            r["stage"] = Value::Null;
        }
        None
    } else {
        for e in entries.iter().filter(|e| e.role == Role::Clutter) {
            if let Some(g) = plan_level::geometry(scene, &node_of_tri, &e.members) {
                if !blocks.iter().any(|b| b.contains(&g)) {
                    notes.push(format!(
                        "clutter {:?} is not inside one block's box: the DRT bake will refuse it",
                        e.name
                    ));
                }
            }
        }
        Some(ClutterFile { clutter })
    };
    let level_name = format!("{stem}.level.toml");
    let clutter_name = format!("{stem}.clutter.toml");
    let config = BakeConfig {
        output_dir: a.output_dir.clone().unwrap_or_else(|| stem.clone()),
        tables: (!spheres.is_empty()).then(|| k.tables.clone()),
        spheres,
        mrt: level.is_some().then(|| k.mrt.clone()),
        fiv,
        mrt_level: level.is_some().then(|| MrtLevelStage {
            level: Some(level_name.clone()),
            maze: None,
            seed: None,
            max_depth: None,
            gate: None,
            output: None,
        }),
        drt: clutter_file.is_some().then(|| DrtStage {
            clutter: Some(clutter_name.clone()),
            example: None,
            rays: Some(k.drt_res_rays.1),
            clutter_rays: None,
            neighborhood: None,
            kc: None,
            kdc: None,
            clutter_res: Some(k.drt_res_rays.0),
            clutter_basis_res: None,
            inpaint: None,
            vector_rays: None,
            volume_res: None,
            target: None,
            gate: None,
            output: None,
        }),
        vo: None,
    };
    if !config.has_stage() {
        print_unassigned(&unassigned);
        return Err(CliError::input(anyhow!(
            "{}: no node has a role this tool can bake ({} unassigned); give roles in node extras \
             ({{\"penumbra\": {{\"role\": …}}}}) or with --role ROLE=GLOB",
            a.scene.display(),
            unassigned.len()
        )));
    }
    let report = json!({
        "scene": a.scene.display().to_string(),
        "preset": format!("{:?}", a.preset).to_lowercase(),
        "entries": report_entries,
        "level": level.as_ref().map(|l| json!({
            "file": level_name,
            "blocks": blocks.iter().zip(&l.blocks).map(|(pb, b)| json!({"node": pb.name, "shape": b.shape, "rotation": b.rotation,
                "translation": b.translation, "scale": b.scale.unwrap_or([1.0; 3])})).collect::<Vec<_>>(),
            "connections": l.connections.len(),
        })),
        "clutter": clutter_file.as_ref().map(|_| clutter_name.clone()),
    });
    Ok(Plan { config, level, clutter: clutter_file, report, notes, unassigned })
}

/// The stage names a config has, with the node lists of each (for reports and tests).
pub fn stage_nodes(c: &BakeConfig) -> Value {
    let nodes = |n: &Option<NodeSelect>| n.as_ref().map(NodeSelect::patterns).unwrap_or_default();
    json!({
        "tables": c.tables.is_some(),
        "spheres": c.spheres.iter().map(|s| json!({"node": nodes(&s.node), "skin": s.skin.unwrap_or(false), "output": s.output_name()})).collect::<Vec<_>>(),
        "fiv": c.fiv.iter().map(|f| json!({"node": nodes(&f.node), "output": f.output_name()})).collect::<Vec<_>>(),
        "mrt": c.mrt.is_some(),
        "mrt_level": c.mrt_level.is_some(),
        "drt": c.drt.is_some(),
    })
}

fn header(a: &PlanArgs) -> String {
    let mut cmd = format!("penumbra plan {}", a.scene.display());
    for (r, g) in &a.roles {
        cmd.push_str(&format!(" --role '{}={g}'", r.name()));
    }
    cmd.push_str(&format!(" --preset {}", format!("{:?}", a.preset).to_lowercase()));
    if a.env != "builtin:area-lights" {
        cmd.push_str(&format!(" --env {}", a.env));
    }
    format!("# Written by `{cmd}`:\n# the bake config this glTF level needs. Paths are relative to this file.\n")
}

/// Lists the unassigned nodes on stderr.
#[allow(clippy::print_stderr)]
fn print_unassigned(unassigned: &[Value]) {
    for u in unassigned {
        eprintln!(
            "unassigned: node {} ({} triangles{}): {}",
            u["node"].as_str().map_or_else(|| format!("#{} (unnamed)", u["index"]), |s| format!("{s:?}")),
            u["triangles"],
            if u["skinned"] == true { ", skinned" } else { "" },
            u["reason"].as_str().unwrap_or("")
        );
    }
}

/// Runs `penumbra plan`.
#[allow(clippy::print_stderr)]
pub fn run(a: &PlanArgs) -> Result<ExitCode, CliError> {
    let scene = load_scene(&a.scene)?;
    let p = make_plan(a, &scene)?;
    let dir = a.output.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let stem = a.output.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "bake".into());
    let cfg_text = format!("{}{}", header(a), toml_text(&p.config)?);
    // what `penumbra bake` will read must load
    penumbra_config::parse_str(&cfg_text, &a.output)
        .map_err(|e| CliError::internal(anyhow!("the planned config does not validate: {e}")))?;
    let mut files: Vec<(PathBuf, String)> = Vec::new();
    if let Some(l) = &p.level {
        let path = dir.join(format!("{stem}.level.toml"));
        let text = format!("{}{}", header(a), l.to_toml());
        penumbra_config::level::parse_level_str(&text, &path)
            .map_err(|e| CliError::internal(anyhow!("the planned level does not parse: {e}")))?;
        files.push((path, text));
    }
    if let Some(c) = &p.clutter {
        let path = dir.join(format!("{stem}.clutter.toml"));
        let text = format!("{}{}", header(a), toml_text(c)?);
        penumbra_config::clutter::parse_clutter_str(&text, &path)
            .map_err(|e| CliError::internal(anyhow!("the planned clutter file does not parse: {e}")))?;
        files.push((path, text));
    }
    files.push((a.output.clone(), cfg_text));
    ensure_parent(&a.output)?;
    // the config goes last; when a write fails, the files this run created are removed again
    let existed: Vec<bool> = files.iter().map(|(f, _)| f.exists()).collect();
    for (i, (path, text)) in files.iter().enumerate() {
        if let Err(e) = write_atomic_text(path, text) {
            for ((f, _), _) in files[..i].iter().zip(&existed).filter(|(_, existed)| !**existed) {
                let _ = std::fs::remove_file(f);
            }
            return Err(e.into());
        }
    }
    let mut report = p.report;
    report["config"] = json!(a.output.display().to_string());
    report["files"] = json!(files.iter().map(|(f, _)| f.display().to_string()).collect::<Vec<_>>());
    report["stages"] = stage_nodes(&p.config);
    report["unassigned"] = json!(p.unassigned);
    report["notes"] = json!(p.notes);
    print_unassigned(&p.unassigned);
    for n in &p.notes {
        eprintln!("note: {n}");
    }
    if a.json {
        print_json(&report);
    } else {
        for r in report["entries"].as_array().into_iter().flatten() {
            eprintln!(
                "{:<10} {:?} → {}",
                r["role"].as_str().unwrap_or(""),
                r["node"].as_str().unwrap_or(""),
                r["stage"].as_str().unwrap_or("(none)")
            );
        }
        for (f, _) in &files {
            eprintln!("wrote {}", f.display());
        }
    }
    Ok(ExitCode::Ok)
}

/// TOML text of a planned file.
fn toml_text<T: serde::Serialize>(v: &T) -> Result<String, CliError> {
    toml::to_string(v).map_err(|e| CliError::internal(anyhow!("cannot write TOML: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn role_options_parse_or_say_what_is_wrong() {
        assert_eq!(parse_role("clutter=Prop_*"), Ok((Role::Clutter, "Prop_*".to_string())));
        assert_eq!(parse_role("block=a=b"), Ok((Role::Block, "a=b".to_string())));
        assert!(parse_role("occluder").unwrap_err().contains("no `=`"));
        assert!(parse_role("lamp=x").unwrap_err().contains("unknown role \"lamp\""));
        assert!(parse_role("character=").unwrap_err().contains("empty name pattern"));
    }

    #[test]
    fn paths_are_written_relative_to_the_config() {
        let r = |t: &str, b: &str| relative_to(Path::new(t), Path::new(b)).unwrap();
        assert_eq!(r("/a/b/scene.glb", "/a/b"), "scene.glb");
        assert_eq!(r("/a/b/scene.glb", "/a/c/d"), "../../b/scene.glb");
        assert_eq!(r("/a/x/../b/s.glb", "/a/./b/out"), "../s.glb");
    }
}
