//! Format compatibility: every asset committed under tests/assets/v1 (written by released
//! versions, never regenerated) must keep loading.

use penumbra_asset::AssetFile;
use penumbra_runtime::ShTables;

#[test]
fn corpus_v1_still_loads() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/assets/v1");
    let mut kinds = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "md") {
            continue;
        }
        let f = AssetFile::open(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        let a = f.asset();
        assert_eq!(a.version().0, 1);
        let meta: serde_json::Value = serde_json::from_str(a.meta_json()).unwrap();
        match a.kind().as_str() {
            "SHTB" => {
                a.require_known(penumbra_sh::tables_asset::SHTB_SECTIONS).unwrap();
                let t = ShTables::from_asset(&a).unwrap();
                assert_eq!(t.order() as u64, meta["params"]["order"].as_u64().unwrap());
                // kind_version 1 has no proxy_log_knots; 2 has them (possibly none), and the
                // runtime reads each knot's row back at its α
                let kv = meta["kind_version"].as_u64().unwrap();
                assert!(kv == 1 || kv == 2, "SHTB kind_version {kv}");
                assert_eq!(a.section("proxy_log_knots").is_some(), kv == 2);
                if kv == 2 {
                    let alphas = meta["metrics"]["proxy_log_knot_alphas"].as_array().unwrap();
                    assert_eq!(t.proxy_log_knot_count(), alphas.len());
                    let rows = a.section("proxy_log_knots").unwrap().as_f32().unwrap();
                    let n = t.order();
                    let mut got = vec![0.0f32; n];
                    for r in rows.chunks_exact(n + 1) {
                        if r[0] < t.alpha_top() || r[0] >= penumbra_runtime::NEAR_CONTACT_ALPHA {
                            continue;
                        }
                        t.proxy_log(r[0], &mut got);
                        let norm = r[1..].iter().map(|v| v * v).sum::<f32>().sqrt();
                        for (g, w) in got.iter().zip(&r[1..]) {
                            assert!((g - w).abs() <= 1e-4 * norm, "knot at {}: {got:?} vs {:?}", r[0], &r[1..]);
                        }
                    }
                }
                // Invariants that hold for every SHTB: no blocker, no log; Γ gives 1*f = f.
                let mut z = vec![1.0f32; t.order()];
                t.cap_log(0.0, &mut z);
                assert!(z.iter().all(|&v| v == 0.0));
                let n2 = t.order() * t.order();
                let mut one = vec![0.0f32; n2];
                one[0] = (4.0 * std::f32::consts::PI).sqrt();
                let f: Vec<f32> = (0..n2).map(|i| 0.1 * i as f32 - 0.3).collect();
                let mut p = vec![0.0f32; n2];
                t.product(&one, &f, &mut p);
                for (a, b) in p.iter().zip(&f) {
                    assert!((a - b).abs() < 1e-5);
                }
            }
            "SPHR" => {
                a.require_known(penumbra_spheres::asset::SPHR_SECTIONS).unwrap();
                let set = penumbra_spheres::asset::read(&a).unwrap();
                assert_eq!(set.spheres.len() as u64, meta["metrics"]["count"].as_u64().unwrap());
                // kind_version 1 has no albedo; 2 may (the runtime view agrees with the baker's)
                let rt = penumbra_runtime::SphereSet::from_asset(&a).unwrap();
                let kv = meta["kind_version"].as_u64().unwrap();
                assert!(kv == 1 || kv == 2, "SPHR kind_version {kv}");
                assert_eq!(rt.has_albedo(), set.albedo.is_some());
                if kv == 1 {
                    assert!(set.albedo.is_none());
                }
                if let Some(al) = &set.albedo {
                    let mean = meta["metrics"]["albedo_mean"].as_array().unwrap();
                    for c in 0..3 {
                        let m = al.iter().map(|x| f64::from(x[c])).sum::<f64>() / al.len() as f64;
                        assert!((m - mean[c].as_f64().unwrap()).abs() < 1e-6);
                    }
                    for (i, x) in al.iter().enumerate() {
                        assert_eq!(rt.albedo(i), Some(*x));
                    }
                }
                // every stored parent bounds its stored children (f64 test on f32 values)
                if let Some(h) = &set.hierarchy {
                    for (l, level) in h.levels.iter().enumerate() {
                        let below: &[[f32; 4]] = h.levels.get(l + 1).map_or(&set.spheres, |v| v.as_slice());
                        for (node, &(first, count)) in level.iter().zip(&h.children[l]) {
                            for c in &below[first as usize..(first + count) as usize] {
                                let d = (0..3).map(|k| (node[k] as f64 - c[k] as f64).powi(2)).sum::<f64>().sqrt();
                                assert!(d + c[3] as f64 <= node[3] as f64);
                            }
                        }
                    }
                }
            }
            "MRTD" => {
                // kind_version 1 (no interface sections): every shape's sections, shapes
                // consistent with meta
                let names: Vec<String> = meta["shapes"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|s| s["name"].as_str().unwrap().to_string())
                    .collect();
                let names: Vec<&str> = names.iter().map(String::as_str).collect();
                let ifaces: Vec<(String, usize)> = meta["interfaces"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|i| {
                        let f = penumbra_transport::level::parse_face(i["face"].as_str().unwrap()).unwrap();
                        (i["shape"].as_str().unwrap().to_string(), f)
                    })
                    .collect();
                let ifaces: Vec<(&str, usize)> = ifaces.iter().map(|(s, f)| (s.as_str(), *f)).collect();
                let known = penumbra_transport::asset::section_names_v3(&names, &ifaces);
                let known: Vec<&str> = known.iter().map(String::as_str).collect();
                a.require_known(&known).unwrap();
                if !ifaces.is_empty() {
                    // kind_version 2: the runtime reads the interface operators
                    let d = penumbra_runtime::mrt::MrtDictionary::from_asset(&a).unwrap();
                    assert_eq!(d.shapes.len(), names.len());
                    // kind_version 4: and the interfaces' vector and volume response
                    let v4 = meta["kind_version"].as_u64() == Some(4);
                    assert_eq!(d.vectors.is_some(), v4);
                    for s in penumbra_transport::asset::INTERFACE_VECTOR_SECTIONS {
                        assert_eq!(a.section(s).is_some(), v4, "{s}");
                    }
                }
                for (s, shape) in names.iter().zip(meta["shapes"].as_array().unwrap()) {
                    let n = shape["texels"].as_u64().unwrap() as usize;
                    let kb = shape["k_b"].as_u64().unwrap() as usize;
                    assert_eq!(a.section(&format!("{s}.u_b")).unwrap().dims(), &[n, kb]);
                    assert_eq!(a.section(&format!("{s}.t_d2b")).unwrap().dims(), &[kb, n]);
                }
            }
            "MRTL" => {
                a.require_known(penumbra_transport::level_ops::MRTL_SECTIONS).unwrap();
                // its dictionary is in the corpus too (matched by CRC-32C)
                let crc = meta["dictionary"]["crc32c"].as_str().unwrap().to_string();
                let dict = std::fs::read_dir(dir)
                    .unwrap()
                    .map(|e| e.unwrap().path())
                    .find(|p| {
                        p.extension().is_some_and(|x| x == "mrtd")
                            && format!("{:08x}", penumbra_asset::crc32c(&std::fs::read(p).unwrap())) == crc
                    })
                    .expect("the level's dictionary is in the corpus");
                let df = AssetFile::open(&dict).unwrap();
                let da = df.asset();
                let d = penumbra_runtime::mrt::MrtDictionary::from_asset(&da).unwrap();
                let l = penumbra_runtime::mrt::MrtLevel::from_asset(&a, &d).unwrap();
                assert_eq!(l.shapes.len() as u64, meta["metrics"]["blocks"].as_u64().unwrap());
            }
            "FIVT" => {
                a.require_known(penumbra_runtime::fiv::FIVT_KNOWN).unwrap();
                let t = penumbra_runtime::fiv::FivTable::from_asset(&a).unwrap();
                let samples: Vec<usize> = meta["params"]["samples"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|v| v.as_u64().unwrap() as usize)
                    .collect();
                assert_eq!(t.samples().to_vec(), samples);
                assert!((f64::from(t.radius()) - meta["frame"]["radius"].as_f64().unwrap()).abs() < 1e-6);
                // Occlusion never exceeds what there is to occlude: on the shell just outside
                // the ball, below the occluder, N·FIV ≤ the unoccluded irradiance.
                let n = [0.0, 1.0, 0.0];
                let tot = t.total_irradiance(n);
                let fiv = t.occluded_fiv([0.0, -1.5 * t.radius(), 0.0]).expect("a sample outside the occluder");
                for c in 0..3 {
                    let occ = fiv[c][1];
                    assert!(occ > 0.0 && occ <= tot[c] * 1.0001, "channel {c}: {occ} vs {}", tot[c]);
                }
            }
            "DRTO" => {
                let mut known = penumbra_transport::drt_asset::DRTO_SECTIONS.to_vec();
                let vector = meta["kind_version"] == 2;
                if vector {
                    known.extend_from_slice(penumbra_transport::drt_asset::DRTO_VECTOR_SECTIONS);
                }
                a.require_known(&known).unwrap();
                // its dictionary and level are in the corpus too (matched by CRC-32C); the
                // runtime validates the operators against both and evaluates them
                let find = |ext: &str, crc: &str| {
                    std::fs::read_dir(dir)
                        .unwrap()
                        .map(|e| e.unwrap().path())
                        .find(|p| {
                            p.extension().is_some_and(|x| x == ext)
                                && format!("{:08x}", penumbra_asset::crc32c(&std::fs::read(p).unwrap())) == crc
                        })
                        .unwrap_or_else(|| panic!("the DRTO's {ext} is in the corpus"))
                };
                let df = AssetFile::open(find("mrtd", meta["inputs"]["dictionary_crc32c"].as_str().unwrap())).unwrap();
                let lf = AssetFile::open(find("mrtl", meta["inputs"]["level_crc32c"].as_str().unwrap())).unwrap();
                let (da, la) = (df.asset(), lf.asset());
                let d = penumbra_runtime::mrt::MrtDictionary::from_asset(&da).unwrap();
                let l = penumbra_runtime::mrt::MrtLevel::from_asset(&la, &d).unwrap();
                let ops = penumbra_runtime::drt::DrtOperators::from_asset(&a, &d, &l).unwrap();
                assert_eq!(ops.clutter_texel_count() as u64, meta["metrics"]["clutter_texels"].as_u64().unwrap());
                let mut mrt = penumbra_runtime::mrt::MrtRuntime::new(d, l);
                let mut drt = penumbra_runtime::drt::DrtRuntime::new(ops, &mrt);
                let n = mrt.texel_count();
                let m = drt.operators().clutter_texel_count();
                let (l_d, l_dc) = (vec![1.0f32; n], vec![1.0f32; m]);
                let (mut s, mut c) = (vec![0.0f32; n], vec![0.0f32; m]);
                let all = penumbra_runtime::drt::Paths::ALL;
                drt.one_bounce(&mut mrt, &l_d, &l_dc, 0, 1.0, all, &mut s, &mut c);
                // uniform unit direct light everywhere: finite, and the clutter receives light
                assert!(s.iter().chain(&c).all(|v| v.is_finite()));
                assert!(c.iter().sum::<f32>() > 0.0);
                // kind_version 2: the vector and volume response reads and evaluates too
                let ops = drt.operators();
                let dv = penumbra_runtime::drt_vec::DrtVector::from_asset(
                    &a,
                    &mrt,
                    ops.instances,
                    ops.receivers,
                    ops.chart_count() as u32,
                )
                .unwrap();
                assert_eq!(dv.is_some(), vector);
                if let Some(mut dv) = dv {
                    let cc = drt.coefficients().to_vec();
                    let (b, kb) = (mrt.coefficients().to_vec(), mrt.level().k_b);
                    let mut sv = vec![[0.0f32; 4]; n];
                    dv.add_scene(&b, kb, 1.0, &cc, &mut sv);
                    let mut cv = vec![[0.0f32; 4]; m];
                    dv.clutter(&b, kb, 1.0, &cc, &mut cv);
                    let mut sh = vec![[0.0f32; 9]; dv.blocks.len() * dv.res.pow(3)];
                    dv.probe_sh(&b, kb, 1.0, &cc, &mut sh);
                    assert!(sv.iter().chain(&cv).flatten().chain(sh.iter().flatten()).all(|v| v.is_finite()));
                    // lit walls: every probe receives light (its DC band), the clutter too
                    assert!(sh.iter().all(|p| p[0] > 0.0));
                    assert!(cv.iter().map(|v| v[0]).sum::<f32>() > 0.0);
                }
            }
            "VOSS" => {
                // every set of meta.counts reads back; weights sum to 1; samples inside the
                // domain; centre sets start at the origin; reflections are unit vectors
                use penumbra_vo::Domain;
                let counts: Vec<usize> =
                    meta["counts"].as_array().unwrap().iter().map(|c| c.as_u64().unwrap() as usize).collect();
                let known = penumbra_vo::asset::section_names(&counts);
                let known: Vec<&str> = known.iter().map(String::as_str).collect();
                a.require_known(&known).unwrap();
                for (domain, centre) in penumbra_vo::bake::FAMILIES {
                    for &n in &counts {
                        let s = penumbra_vo::asset::read_set(&a, domain, centre, n).unwrap().unwrap();
                        assert_eq!(s.points.len(), n);
                        assert!((s.weights.iter().sum::<f64>() - 1.0).abs() < 1e-5);
                        assert!(s.points.iter().all(|p| p.iter().map(|x| x * x).sum::<f64>() < 1.0));
                        if centre {
                            assert_eq!(s.points[0], [0.0; 3]);
                        }
                    }
                }
                for d in [Domain::Disk, Domain::Ball] {
                    for r in penumbra_vo::asset::read_reflections(&a, d).unwrap() {
                        assert!((r.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-5);
                    }
                }
            }
            other => panic!("no compatibility check for kind {other}"),
        }
        kinds.push(a.kind().as_str().to_string());
    }
    for kind in ["SHTB", "SPHR", "MRTD", "MRTL", "FIVT", "DRTO", "VOSS"] {
        assert!(kinds.iter().any(|k| k == kind), "corpus must hold an {kind} asset");
    }
}
