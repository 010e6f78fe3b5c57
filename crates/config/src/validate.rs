//! Semantic validation beyond types: ranges and names, each issue with its key path.

use crate::types::BakeConfig;

/// One validation problem.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Issue {
    /// Dotted key path, e.g. `tables.order`.
    pub key: String,
    /// What is wrong and what is allowed.
    pub message: String,
}

fn issue(key: &str, message: impl Into<String>) -> Issue {
    Issue { key: key.to_string(), message: message.into() }
}

/// A file name without directories or traversal.
fn plain_file_name(s: &str) -> bool {
    !s.is_empty() && !s.contains(['/', '\\']) && s != "." && s != ".."
}

/// Checks every value range of the config; returns all issues in document order.
pub fn validate(c: &BakeConfig) -> Vec<Issue> {
    let mut out = Vec::new();
    if c.output_dir.trim().is_empty() {
        out.push(issue("output_dir", "must not be empty"));
    }
    if let Some(t) = &c.tables {
        if !(2..=8).contains(&t.order) {
            out.push(issue("tables.order", format!("{} is out of range (allowed: 2..=8)", t.order)));
        }
        if let Some(k) = t.theta_samples {
            if !(16..=16384).contains(&k) {
                out.push(issue("tables.theta_samples", format!("{k} is out of range (allowed: 16..=16384)")));
            }
        }
        if let Some(tol) = t.shading_tolerance {
            if !(tol > 0.0 && tol < 1.0) {
                out.push(issue("tables.shading_tolerance", format!("{tol} is out of range (allowed: 0 < T < 1)")));
            }
        }
        if let Some(env) = &t.env {
            if env.trim().is_empty() {
                out.push(issue("tables.env", "must not be empty"));
            }
        }
        if let Some(o) = &t.output {
            if !plain_file_name(o) {
                out.push(issue("tables.output", format!("{o:?} must be a plain file name (no directories)")));
            }
        }
    }
    let mut outputs: Vec<String> = Vec::new();
    for (i, sp) in c.spheres.iter().enumerate() {
        let key = |k: &str| format!("spheres[{i}].{k}");
        if sp.mesh.trim().is_empty() {
            out.push(issue(&key("mesh"), "must not be empty"));
        }
        let given = [sp.count.is_some(), sp.target_error.is_some(), sp.target_union.is_some()];
        if given.iter().filter(|&&g| g).count() != 1 {
            out.push(issue(&format!("spheres[{i}]"), "give exactly one of `count`, `target_error` and `target_union`"));
        }
        if let Some(n) = sp.count
            && !(1..=4096).contains(&n)
        {
            out.push(issue(&key("count"), format!("{n} is out of range (allowed: 1..=4096)")));
        }
        for (k, v) in [("target_error", sp.target_error), ("target_union", sp.target_union)] {
            if let Some(e) = v
                && !(e > 0.0 && e.is_finite())
            {
                out.push(issue(&key(k), format!("{e} is out of range (allowed: a positive number)")));
            }
        }
        if let Some(m) = sp.max_count {
            if sp.count.is_some() {
                out.push(issue(
                    &key("max_count"),
                    "caps a `target_error`/`target_union` search; with `count` it has no effect",
                ));
            } else if !(1..=4096).contains(&m) {
                out.push(issue(&key("max_count"), format!("{m} is out of range (allowed: 1..=4096)")));
            }
        }
        if let Some(g) = sp.grid {
            if !(8..=256).contains(&g) {
                out.push(issue(&key("grid"), format!("{g} is out of range (allowed: 8..=256)")));
            }
        }
        if let Some(it) = sp.iterations {
            if !(1..=10000).contains(&it) {
                out.push(issue(&key("iterations"), format!("{it} is out of range (allowed: 1..=10000)")));
            }
        }
        if let Some(a) = sp.albedo
            && !a.rgb().iter().all(|v| (0.0..=1.0).contains(v))
        {
            out.push(issue(&key("albedo"), format!("{:?} is out of range (allowed: each in [0, 1])", a.rgb())));
        }
        if let Some(m) = node_select_issue(sp.node.as_ref()) {
            out.push(issue(&key("node"), m));
        }
        if sp.skin_padding == Some(true) && sp.skin != Some(true) {
            out.push(issue(&key("skin_padding"), "pads the skinned set: it needs `skin = true`"));
        }
        if let Some(o) = &sp.output {
            if !plain_file_name(o) {
                out.push(issue(&key("output"), format!("{o:?} must be a plain file name (no directories)")));
            }
        }
        let name = sp.output_name();
        if outputs.contains(&name) {
            out.push(issue(
                &key("output"),
                format!("{name:?} is already written by another [[spheres]] entry; set `output`"),
            ));
        }
        outputs.push(name);
    }
    for (i, f) in c.fiv.iter().enumerate() {
        let key = |k: &str| format!("fiv[{i}].{k}");
        if let Some(m) = node_select_issue(f.node.as_ref()) {
            out.push(issue(&key("node"), m));
        } else if f.node.is_some() && f.mesh.starts_with("builtin:") {
            out.push(issue(&key("node"), "selects glTF nodes: it needs a glTF `mesh`, not a builtin occluder"));
        }
        if let Some(g) = &f.gate {
            if g.max_nrmse.is_none() && g.max_nrmse_visible.is_none() {
                out.push(issue(&key("gate"), "give `max_nrmse` or `max_nrmse_visible`"));
            }
            for (k, x) in [("gate.max_nrmse", g.max_nrmse), ("gate.max_nrmse_visible", g.max_nrmse_visible)] {
                if let Some(x) = x
                    && crate::gate::bad_bound(x)
                {
                    out.push(issue(&key(k), format!("{x} is out of range (allowed: a finite value > 0)")));
                }
            }
        }
        if let Some(t) = f.target {
            if crate::gate::bad_bound(t) {
                out.push(issue(&key("target"), format!("{t} is out of range (allowed: a finite value > 0)")));
            }
            for (k, given) in [("samples", f.samples.is_some()), ("cube_size", f.cube_size.is_some())] {
                if given {
                    out.push(issue(&key(k), "`target` chooses it: give one of `target` or the knob"));
                }
            }
        }
        if f.mesh.trim().is_empty() {
            out.push(issue(&key("mesh"), "must not be empty"));
        }
        if f.env.trim().is_empty() {
            out.push(issue(&key("env"), "must not be empty"));
        }
        // the same ranges as penumbra_fiv::layout and penumbra_fiv::bake
        if let Some([a, p, k]) = f.samples {
            for (name, v, lo, hi) in [("azimuth", a, 2, 4096), ("polar", p, 2, 2049), ("radial", k, 2, 1024)] {
                if !(lo..=hi).contains(&v) {
                    out.push(issue(
                        &key("samples"),
                        format!("{name} count {v} is out of range (allowed: {lo}..={hi})"),
                    ));
                }
            }
            let n = a as u64 * p as u64 * k as u64;
            if n > 1 << 24 {
                out.push(issue(&key("samples"), format!("{n} samples are too many (allowed: at most 16777216)")));
            }
        }
        let r_min = f.r_min.unwrap_or(1.0);
        let r_max = f.r_max.unwrap_or(8.0);
        if !(r_min.is_finite() && (0.0..1000.0).contains(&r_min)) {
            out.push(issue(&key("r_min"), format!("{r_min} is out of range (allowed: 0 <= r_min < 1000)")));
        } else if !(r_max.is_finite() && r_max > r_min && r_max <= 1000.0) {
            out.push(issue(&key("r_max"), format!("{r_max} is out of range (allowed: r_min < r_max <= 1000)")));
        }
        if let Some(s) = f.cube_size {
            if !(1..=512).contains(&s) {
                out.push(issue(&key("cube_size"), format!("{s} is out of range (allowed: 1..=512)")));
            }
        }
        if let Some(s) = f.irradiance_size {
            if !(1..=256).contains(&s) {
                out.push(issue(&key("irradiance_size"), format!("{s} is out of range (allowed: 1..=256)")));
            }
        }
        if let Some(o) = &f.output {
            if !plain_file_name(o) {
                out.push(issue(&key("output"), format!("{o:?} must be a plain file name (no directories)")));
            }
        }
        let name = f.output_name();
        if outputs.contains(&name) || c.tables.as_ref().is_some_and(|t| t.output_name() == name) {
            out.push(issue(&key("output"), format!("{name:?} is written by another stage too (set `output`)")));
        }
        outputs.push(name);
    }
    if let Some(m) = &c.mrt {
        validate_mrt(m, &mut out);
    }
    if let Some(d) = &c.drt {
        validate_drt(d, c, &mut out);
    }
    if let Some(l) = &c.mrt_level {
        validate_mrt_level(l, c.mrt.as_ref(), &mut out);
    }
    if let Some(v) = &c.vo {
        validate_vo(v, &mut out);
    }
    if !c.has_stage() {
        out.push(issue(
            "stages",
            "the config names no stage to bake (add a stage table such as [tables], [[spheres]], [[fiv]], [mrt] or [vo])",
        ));
    }
    out
}

/// What is wrong with a node selection, if anything: an empty list or an empty pattern.
pub fn node_select_issue(n: Option<&crate::types::NodeSelect>) -> Option<String> {
    let p = n?.patterns();
    if p.is_empty() {
        Some("an empty list selects nothing: give at least one name pattern".into())
    } else if p.iter().any(String::is_empty) {
        Some("a pattern must not be empty".into())
    } else {
        None
    }
}

/// Ranges of the `[mrt]` stage (the same as `penumbra mrt dict`'s options).
fn validate_mrt(m: &crate::types::MrtStage, out: &mut Vec<Issue>) {
    let range = |out: &mut Vec<Issue>, key: &str, v: Option<u32>, lo: u32, hi: u32| {
        if let Some(v) = v {
            if !(lo..=hi).contains(&v) {
                out.push(issue(key, format!("{v} is out of range (allowed: {lo}..={hi})")));
            }
        }
    };
    if let Some(d) = &m.dictionary {
        if d != "cube2d" && d != "closed-cube" {
            out.push(issue(
                "mrt.dictionary",
                format!("{d:?} is not a dictionary (allowed: \"cube2d\", \"closed-cube\")"),
            ));
        }
    }
    range(out, "mrt.face_res", m.face_res, 2, 24);
    range(out, "mrt.kd", m.kd, 1, 256);
    let kd = m.kd.unwrap_or(64);
    range(out, "mrt.kb", m.kb, 1, kd.max(1));
    range(out, "mrt.rays", m.rays, 16, 1 << 20);
    if let Some(a) = m.albedo {
        if !(a > 0.0 && a <= 1.0) {
            out.push(issue("mrt.albedo", format!("{a} is out of range (allowed: 0 < A <= 1)")));
        }
    }
    range(out, "mrt.enrich", m.enrich, 0, 8);
    range(out, "mrt.fallback_modes", m.fallback_modes, 0, kd);
    if m.enrich == Some(0) && m.exclude_same_face != Some(false) {
        out.push(issue(
            "mrt.exclude_same_face",
            "the same-face exclusion needs enrichment (enrich >= 1); set exclude_same_face = false with enrich = 0",
        ));
    }
    if let Some(g) = &m.gather {
        if g != "bilinear" && g != "exact" {
            out.push(issue("mrt.gather", format!("{g:?} is not a gather (allowed: \"bilinear\", \"exact\")")));
        }
    }
    if let Some(l) = &m.light_layout {
        if l != "lattice" && l != "cells" {
            out.push(issue("mrt.light_layout", format!("{l:?} is not a layout (allowed: \"lattice\", \"cells\")")));
        }
    }
    if let Some(r) = m.light_radius {
        if !(r > 0.0 && r <= 0.08) {
            out.push(issue("mrt.light_radius", format!("{r} is out of range (allowed: 0 < r <= 0.08)")));
        }
    }
    range(out, "mrt.vector_rays", m.vector_rays, 16, 65536);
    range(out, "mrt.volume_res", m.volume_res, 1, 16);
    range(out, "mrt.probe_rays", m.probe_rays, 16, 65536);
    range(out, "mrt.test_lights", m.test_lights, 1, 64);
    range(out, "mrt.reference_rays", m.reference_rays, 2, 65536);
    range(out, "mrt.k_rlf", m.k_rlf, 1, 512);
    range(out, "mrt.k_r", m.k_r, 1, m.k_rlf.unwrap_or(128).max(1));
    range(out, "mrt.lf_spatial", m.lf_spatial, 2, 32);
    range(out, "mrt.lf_dir", m.lf_dir, 2, 64);
    range(out, "mrt.lf_super", m.lf_super, 1, 8);
    range(out, "mrt.interface_enrich", m.interface_enrich, 0, 8);
    range(out, "mrt.response_rays", m.response_rays, 16, 65536);
    if let Some(o) = &m.output {
        if !plain_file_name(o) {
            out.push(issue("mrt.output", format!("{o:?} must be a plain file name (no directories)")));
        }
    }
}

fn validate_drt(d: &crate::types::DrtStage, c: &crate::types::BakeConfig, out: &mut Vec<Issue>) {
    if let Some(g) = &d.gate
        && crate::gate::bad_bound(g.max_rel_error)
    {
        out.push(issue(
            "drt.gate.max_rel_error",
            format!("{} is out of range (allowed: a finite value > 0)", g.max_rel_error),
        ));
    }
    if let Some(t) = d.target {
        if crate::gate::bad_bound(t) {
            out.push(issue("drt.target", format!("{t} is out of range (allowed: a finite value > 0)")));
        }
        for (k, given) in [("drt.rays", d.rays.is_some()), ("drt.clutter_rays", d.clutter_rays.is_some())] {
            if given {
                out.push(issue(k, "`target` chooses it: give one of `target` or the knob"));
            }
        }
        if d.vector_rays.is_some() {
            out.push(issue(
                "drt.vector_rays",
                "`target` chooses the scalar operators' knobs: bake the vector operators with the chosen `rays`",
            ));
        }
    }
    if c.mrt.is_none() {
        out.push(issue("drt", "[drt] needs the [mrt] stage (its dictionary)"));
    }
    match (&d.clutter, &d.example) {
        (Some(_), Some(_)) | (None, None) => out.push(issue("drt", "give exactly one of `clutter` or `example`")),
        (Some(_), None) if c.mrt_level.is_none() => {
            out.push(issue("drt.clutter", "[drt] with a clutter file needs the [mrt_level] stage (its level)"))
        }
        (None, Some(e)) if !["pillars", "cornell", "maze-boxes"].contains(&e.as_str()) => {
            out.push(issue("drt.example", format!("{e:?} is not one of pillars, cornell, maze-boxes")))
        }
        _ => {}
    }
    for (key, v, lo, hi) in [
        ("drt.rays", d.rays, 16, 1 << 20),
        ("drt.clutter_rays", d.clutter_rays, 16, 1 << 20),
        ("drt.neighborhood", d.neighborhood, 0, 16),
        ("drt.kc", d.kc, 1, 256),
        ("drt.kdc", d.kdc, 1, 4096),
        ("drt.clutter_res", d.clutter_res, 2, 64),
        ("drt.clutter_basis_res", d.clutter_basis_res, 1, 64),
        ("drt.vector_rays", d.vector_rays, 16, 1 << 18),
        ("drt.volume_res", d.volume_res, 1, 16),
    ] {
        if let Some(v) = v {
            if !(lo..=hi).contains(&v) {
                out.push(issue(key, format!("{v} is out of range (allowed: {lo}..={hi})")));
            }
        }
    }
    if d.volume_res.is_some() && d.vector_rays.is_none() {
        out.push(issue("drt.volume_res", "needs `vector_rays` (the U_dyn probes come with the vector operators)"));
    }
    let (r, s) = (d.clutter_res.unwrap_or(16), d.clutter_basis_res.unwrap_or(2));
    if s > 0 && r % s != 0 {
        out.push(issue("drt.clutter_basis_res", format!("{s} must divide clutter_res {r}")));
    }
    if let Some(o) = &d.output {
        if !plain_file_name(o) {
            out.push(issue("drt.output", format!("{o:?} must be a plain file name (no directories)")));
        }
    }
}

fn validate_mrt_level(l: &crate::types::MrtLevelStage, mrt: Option<&crate::types::MrtStage>, out: &mut Vec<Issue>) {
    if let Some(g) = &l.gate
        && crate::gate::bad_bound(g.max_rel_error)
    {
        out.push(issue(
            "mrt_level.gate.max_rel_error",
            format!("{} is out of range (allowed: a finite value > 0)", g.max_rel_error),
        ));
    }
    match mrt {
        None => out.push(issue("mrt_level", "[mrt_level] needs the [mrt] stage (its dictionary)")),
        Some(m) if m.interfaces == Some(false) => {
            out.push(issue("mrt.interfaces", "[mrt_level] needs a dictionary with interfaces (interfaces = true)"))
        }
        Some(m) if m.dictionary.as_deref() == Some("closed-cube") => out.push(issue(
            "mrt.dictionary",
            "[mrt_level] needs the cube2d dictionary (the closed cube has no interfaces)",
        )),
        _ => {}
    }
    match (&l.level, l.maze) {
        (Some(_), Some(_)) | (None, None) => out.push(issue("mrt_level", "give exactly one of `level` or `maze`")),
        _ => {}
    }
    for (key, v, lo, hi) in [("mrt_level.maze", l.maze, 1, 4096), ("mrt_level.max_depth", l.max_depth, 0, 64)] {
        if let Some(v) = v {
            if !(lo..=hi).contains(&v) {
                out.push(issue(key, format!("{v} is out of range (allowed: {lo}..={hi})")));
            }
        }
    }
    if let Some(o) = &l.output {
        if !plain_file_name(o) {
            out.push(issue("mrt_level.output", format!("{o:?} must be a plain file name (no directories)")));
        }
    }
}

fn validate_vo(v: &crate::types::VoStage, out: &mut Vec<Issue>) {
    if let Some(g) = &v.gate {
        if crate::gate::bad_bound(g.max_rmse) {
            out.push(issue(
                "vo.gate.max_rmse",
                format!("{} is out of range (allowed: a finite value > 0)", g.max_rmse),
            ));
        }
        if g.mesh.trim().is_empty() {
            out.push(issue("vo.gate.mesh", "must not be empty"));
        }
    }
    if let Some(c) = &v.counts {
        if c.is_empty() || c.iter().any(|&n| !(1..=256).contains(&n)) {
            out.push(issue("vo.counts", format!("{c:?} is out of range (allowed: a non-empty list of 1..=256)")));
        } else if c.windows(2).any(|w| w[0] >= w[1]) {
            out.push(issue("vo.counts", format!("{c:?} must be strictly increasing")));
        }
    }
    for (key, x, lo, hi) in [("vo.starts", v.starts, 1, 1000), ("vo.noise_trials", v.noise_trials, 1, 1_000_000)] {
        if let Some(x) = x {
            if !(lo..=hi).contains(&x) {
                out.push(issue(key, format!("{x} is out of range (allowed: {lo}..={hi})")));
            }
        }
    }
    if let Some(o) = &v.output {
        if !plain_file_name(o) {
            out.push(issue("vo.output", format!("{o:?} must be a plain file name (no directories)")));
        }
    }
}
