//! A small, dependency-free SVG line/scatter plot for `penumbra sweep` (deterministic text,
//! viewable in any browser). Log-scale x axis, linear y axis, one polyline per series with
//! point labels, and optionally the Pareto front (lower-left envelope) as a dashed line with
//! hollow squares on its points.

use std::fmt::Write;

/// One series: a name and labelled points `(x, y, label)`.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Points in drawing order.
    pub points: Vec<(f64, f64, String)>,
}

/// A panel: title, axis labels and series.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Title above the panel.
    pub title: String,
    /// x-axis label (the axis is logarithmic).
    pub x_label: String,
    /// y-axis label.
    pub y_label: String,
    /// The data.
    pub series: Vec<Series>,
    /// Points of the Pareto front, drawn as a dashed black line with hollow squares (empty: none).
    pub front: Vec<(f64, f64)>,
}

/// Which points are on the Pareto front when both coordinates are to be minimised: no other
/// point is at least as good in both and better in one. Non-finite points are never on it.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<bool> {
    let ok = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite();
    points
        .iter()
        .map(|p| ok(p) && !points.iter().any(|q| ok(q) && q.0 <= p.0 && q.1 <= p.1 && (q.0 < p.0 || q.1 < p.1)))
        .collect()
}

const W: f64 = 560.0;
const H: f64 = 400.0;
const M: (f64, f64, f64, f64) = (70.0, 20.0, 40.0, 55.0); // left, right, top, bottom
const COLORS: [&str; 8] = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2"];

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// Renders panels side by side as one SVG document.
pub fn render(panels: &[Panel]) -> String {
    let mut s = String::new();
    let total_w = W * panels.len() as f64;
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{total_w}" height="{H}" font-family="sans-serif" font-size="11">"#
    );
    let _ = writeln!(s, r#"<rect width="{total_w}" height="{H}" fill="white"/>"#);
    for (pi, p) in panels.iter().enumerate() {
        let ox = W * pi as f64;
        let pts: Vec<(f64, f64)> = p.series.iter().flat_map(|se| se.points.iter().map(|q| (q.0, q.1))).collect();
        let finite: Vec<(f64, f64)> =
            pts.into_iter().filter(|(x, y)| x.is_finite() && *x > 0.0 && y.is_finite()).collect();
        let (mut x0, mut x1) = finite.iter().fold((f64::INFINITY, 0.0f64), |a, q| (a.0.min(q.0), a.1.max(q.0)));
        let y1 = finite.iter().fold(0.0f64, |a, q| a.max(q.1)) * 1.08;
        if !(x0.is_finite() && x1 > 0.0) {
            (x0, x1) = (1.0, 10.0);
        }
        let (lx0, lx1) = ((x0.log10() - 0.1).floor(), (x1.log10() + 0.1).ceil());
        let y1 = if y1 > 0.0 { y1 } else { 1.0 };
        let (pw, ph) = (W - M.0 - M.1, H - M.2 - M.3);
        let sx = |x: f64| ox + M.0 + (x.log10() - lx0) / (lx1 - lx0) * pw;
        let sy = |y: f64| M.2 + ph - y / y1 * ph;
        let _ =
            writeln!(s, r#"<text x="{}" y="20" font-size="13" font-weight="bold">{}</text>"#, ox + M.0, esc(&p.title));
        let _ = writeln!(
            s,
            r##"<rect x="{}" y="{}" width="{pw}" height="{ph}" fill="none" stroke="#333"/>"##,
            ox + M.0,
            M.2
        );
        // x decades
        let mut d = lx0;
        while d <= lx1 + 1e-9 {
            let x = sx(10f64.powf(d));
            let _ = writeln!(s, r##"<line x1="{x}" y1="{}" x2="{x}" y2="{}" stroke="#ddd"/>"##, M.2, M.2 + ph);
            let _ = writeln!(s, r#"<text x="{x}" y="{}" text-anchor="middle">1e{}</text>"#, M.2 + ph + 15.0, d as i64);
            d += 1.0;
        }
        // y ticks
        for k in 0..=5 {
            let y = y1 * k as f64 / 5.0;
            let yy = sy(y);
            let _ =
                writeln!(s, r##"<line x1="{}" y1="{yy}" x2="{}" y2="{yy}" stroke="#eee"/>"##, ox + M.0, ox + M.0 + pw);
            let _ = writeln!(s, r#"<text x="{}" y="{}" text-anchor="end">{:.3}</text>"#, ox + M.0 - 5.0, yy + 4.0, y);
        }
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
            ox + M.0 + pw / 2.0,
            H - 12.0,
            esc(&p.x_label)
        );
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}" text-anchor="middle" transform="rotate(-90 {} {})">{}</text>"#,
            ox + 16.0,
            M.2 + ph / 2.0,
            ox + 16.0,
            M.2 + ph / 2.0,
            esc(&p.y_label)
        );
        for (si, se) in p.series.iter().enumerate() {
            let c = COLORS[si % COLORS.len()];
            let path: Vec<String> = se
                .points
                .iter()
                .filter(|q| q.0 > 0.0 && q.0.is_finite() && q.1.is_finite())
                .map(|q| format!("{:.1},{:.1}", sx(q.0), sy(q.1)))
                .collect();
            let _ =
                writeln!(s, r#"<polyline points="{}" fill="none" stroke="{c}" stroke-width="1.5"/>"#, path.join(" "));
            for q in se.points.iter().filter(|q| q.0 > 0.0 && q.0.is_finite() && q.1.is_finite()) {
                let _ = writeln!(s, r#"<circle cx="{:.1}" cy="{:.1}" r="3" fill="{c}"/>"#, sx(q.0), sy(q.1));
                let _ = writeln!(
                    s,
                    r#"<text x="{:.1}" y="{:.1}" font-size="9" fill="{c}">{}</text>"#,
                    sx(q.0) + 4.0,
                    sy(q.1) - 4.0,
                    esc(&q.2)
                );
            }
            let ly = M.2 + 14.0 + 14.0 * si as f64;
            let lx = ox + M.0 + pw - 110.0;
            let _ = writeln!(
                s,
                r#"<line x1="{lx}" y1="{}" x2="{}" y2="{}" stroke="{c}" stroke-width="2"/>"#,
                ly - 4.0,
                lx + 18.0,
                ly - 4.0
            );
            let _ = writeln!(s, r#"<text x="{}" y="{ly}">{}</text>"#, lx + 22.0, esc(&se.name));
        }
        let mut front: Vec<(f64, f64)> =
            p.front.iter().copied().filter(|q| q.0 > 0.0 && q.0.is_finite() && q.1.is_finite()).collect();
        if !front.is_empty() {
            front.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.total_cmp(&a.1)));
            let path: Vec<String> = front.iter().map(|q| format!("{:.1},{:.1}", sx(q.0), sy(q.1))).collect();
            let _ = writeln!(
                s,
                r##"<polyline points="{}" fill="none" stroke="#000" stroke-width="1" stroke-dasharray="4 3"/>"##,
                path.join(" ")
            );
            // hollow squares, so that data points stay countable as the only circles
            for q in &front {
                let _ = writeln!(
                    s,
                    r##"<rect x="{:.1}" y="{:.1}" width="11" height="11" fill="none" stroke="#000" stroke-width="1"/>"##,
                    sx(q.0) - 5.5,
                    sy(q.1) - 5.5
                );
            }
            let ly = M.2 + 14.0 + 14.0 * p.series.len() as f64;
            let lx = ox + M.0 + pw - 110.0;
            let _ = writeln!(
                s,
                r##"<line x1="{lx}" y1="{}" x2="{}" y2="{}" stroke="#000" stroke-dasharray="4 3"/>"##,
                ly - 4.0,
                lx + 18.0,
                ly - 4.0
            );
            let _ = writeln!(s, r#"<text x="{}" y="{ly}">Pareto front</text>"#, lx + 22.0);
        }
    }
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_points_and_escapes_text() {
        let p = Panel {
            title: "a < b".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![Series { name: "s".into(), points: vec![(1.0, 0.5, "8".into()), (100.0, 0.1, "64".into())] }],
            front: Vec::new(),
        };
        let svg = render(&[p.clone(), p]);
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>\n"));
        assert_eq!(svg.matches("<circle").count(), 4);
        assert!(svg.contains("a &lt; b") && !svg.contains("a < b"));
        assert!(!svg.contains("Pareto"));
    }

    #[test]
    fn pareto_front_keeps_the_undominated_points() {
        // (1, 5) and (2, 1) are undominated; (3, 2) is worse than (2, 1) in both; (2, 3) is
        // dominated by (2, 1) (equal x, larger y); NaN never counts
        let pts = [(1.0, 5.0), (2.0, 1.0), (3.0, 2.0), (2.0, 3.0), (f64::NAN, 0.0)];
        assert_eq!(pareto_front(&pts), [true, true, false, false, false]);
        let p = Panel {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![Series { name: "s".into(), points: vec![(1.0, 5.0, "a".into()), (2.0, 1.0, "b".into())] }],
            front: vec![(1.0, 5.0), (2.0, 1.0)],
        };
        let svg = render(&[p]);
        assert!(svg.contains("Pareto front") && svg.contains("stroke-dasharray"));
        assert_eq!(svg.matches("<circle").count(), 2, "one circle per data point");
        assert_eq!(svg.matches(r#"width="11""#).count(), 2, "one square per front point");
    }
}
