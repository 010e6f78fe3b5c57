//! The pictures `penumbra verify … --image` writes: titled panels upscaled to at least
//! [`MIN_PANEL`] pixels, a colour bar that gives the difference panel's scale in the
//! metric's units, and a caption with the key figures. Text is drawn with the public-domain
//! 8×8 bitmap font of `font8x8` (embedded, no system font), doubled to 16 px; characters
//! outside ASCII are drawn as the nearest ASCII (`−` as `-`, `×` as `x`, `Δ` as `d`) or `?`.

/// Smallest panel side in pixels after upscaling (a panel is never scaled past
/// [`MAX_PANEL`] on its longer side).
pub const MIN_PANEL: usize = 512;
/// Largest panel side in pixels.
pub const MAX_PANEL: usize = 4096;
/// Text scale: each font pixel is a `TEXT × TEXT` square.
const TEXT: usize = 2;
/// Height of a line of text (16 px glyphs and 6 px leading).
const LINE: usize = 8 * TEXT + 6;
const MARGIN: usize = 16;
const GAP: usize = 16;
const BACKGROUND: [u8; 3] = [40, 40, 40];
const INK: [u8; 3] = [235, 235, 235];

/// One picture: `w × h` pixels, row-major from the top.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Title drawn above it.
    pub title: String,
    /// Width in pixels.
    pub w: usize,
    /// Height in pixels.
    pub h: usize,
    /// `w · h` colours.
    pub rgb: Vec<[u8; 3]>,
}

impl Panel {
    /// A panel of `w × h` pixels from `pixel(i, j)` (column `i`, row `j` from the top).
    pub fn from_fn(title: impl Into<String>, w: usize, h: usize, pixel: impl Fn(usize, usize) -> [u8; 3]) -> Self {
        let rgb = (0..w * h).map(|k| pixel(k % w, k / w)).collect();
        Self { title: title.into(), w, h, rgb }
    }
}

/// The colour scale of the difference panel: `map(t)` for `t ∈ [0, 1]` spans `lo..hi`.
#[derive(Debug, Clone)]
pub struct ColorBar {
    /// What the scale measures, with its units.
    pub label: String,
    /// Value at the left end.
    pub lo: f64,
    /// Value at the right end.
    pub hi: f64,
    /// Colour at `t ∈ [0, 1]`.
    pub map: fn(f64) -> [u8; 3],
}

/// Panels side by side, an optional colour bar, caption lines.
#[derive(Debug, Clone, Default)]
pub struct Figure {
    /// Panels, left to right.
    pub panels: Vec<Panel>,
    /// Scale of the difference panel.
    pub colorbar: Option<ColorBar>,
    /// Caption lines (key figures and settings).
    pub caption: Vec<String>,
}

/// Blue (−1) – white (0) – red (+1) for `t ∈ [0, 1]` (`t = ½` is zero).
pub fn diverging(t: f64) -> [u8; 3] {
    let d = (2.0 * t - 1.0).clamp(-1.0, 1.0);
    let f = |x: f64| (255.0 * x).round() as u8;
    if d >= 0.0 { [255, f(1.0 - d), f(1.0 - d)] } else { [f(1.0 + d), f(1.0 + d), 255] }
}

/// Black (0) to white (1).
pub fn gray(t: f64) -> [u8; 3] {
    let g = (255.0 * t.clamp(0.0, 1.0)).round() as u8;
    [g, g, g]
}

/// Integer upscale of a `w × h` panel: its shorter side reaches [`MIN_PANEL`] unless its
/// longer side would pass [`MAX_PANEL`].
pub fn scale_of(w: usize, h: usize) -> usize {
    let (short, long) = (w.min(h).max(1), w.max(h).max(1));
    MIN_PANEL.div_ceil(short).min(MAX_PANEL / long).max(1)
}

/// A tick label: three significant digits, exponent form outside `[1e-3, 1e4)`.
pub fn tick(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if !(1e-3..1e4).contains(&a) {
        format!("{v:.2e}")
    } else {
        let digits = (2 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.digits$}")
    }
}

fn ascii(c: char) -> u8 {
    match c {
        ' '..='~' => c as u8,
        '−' | '–' | '—' => b'-',
        '×' | '·' => {
            if c == '×' {
                b'x'
            } else {
                b'.'
            }
        }
        'Δ' => b'd',
        'ρ' => b'p',
        '²' => b'2',
        '³' => b'3',
        '±' => b'+',
        '≤' => b'<',
        '≥' => b'>',
        _ => b'?',
    }
}

/// Width in pixels of `s` drawn by [`text`].
pub fn text_width(s: &str) -> usize {
    s.chars().count() * 8 * TEXT
}

/// An RGB canvas.
struct Canvas {
    w: usize,
    h: usize,
    px: Vec<u8>,
}

impl Canvas {
    fn put(&mut self, x: usize, y: usize, c: [u8; 3]) {
        if x < self.w && y < self.h {
            let o = (y * self.w + x) * 3;
            self.px[o..o + 3].copy_from_slice(&c);
        }
    }

    /// `s` with its top-left corner at `(x, y)`.
    fn text(&mut self, x: usize, y: usize, s: &str) {
        for (k, c) in s.chars().enumerate() {
            let glyph = font8x8::legacy::BASIC_LEGACY[usize::from(ascii(c) & 0x7F)];
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    // bit 0 is the leftmost pixel
                    if bits >> col & 1 == 1 {
                        for dy in 0..TEXT {
                            for dx in 0..TEXT {
                                self.put(x + (k * 8 + col) * TEXT + dx, y + row * TEXT + dy, INK);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// The figure as a PNG file.
pub fn render(fig: &Figure) -> Vec<u8> {
    let scaled: Vec<(usize, usize, usize)> = fig
        .panels
        .iter()
        .map(|p| {
            let s = scale_of(p.w, p.h);
            (s, p.w * s, p.h * s)
        })
        .collect();
    let panels_w: usize = scaled.iter().map(|s| s.1).sum::<usize>() + GAP * fig.panels.len().saturating_sub(1);
    let panels_h = scaled.iter().map(|s| s.2).max().unwrap_or(0);
    let bar_w = MIN_PANEL.min(panels_w.max(MIN_PANEL));
    let bar_h = if fig.colorbar.is_some() { LINE + 20 + 4 + LINE } else { 0 };
    let caption_w = fig.caption.iter().map(|l| text_width(l)).max().unwrap_or(0);
    let label_w = fig.colorbar.as_ref().map_or(0, |b| text_width(&b.label));
    let w = 2 * MARGIN + panels_w.max(caption_w).max(bar_w).max(label_w);
    let h = MARGIN + LINE + panels_h + GAP + bar_h + fig.caption.len() * LINE + MARGIN;
    let mut c = Canvas { w, h, px: BACKGROUND.iter().copied().cycle().take(w * h * 3).collect() };
    let mut x0 = MARGIN;
    for (p, &(s, pw, _)) in fig.panels.iter().zip(&scaled) {
        // a title longer than its panel is cut at the panel's edge
        let title: String = p.title.chars().take((pw / (8 * TEXT)).max(1)).collect();
        c.text(x0, MARGIN, &title);
        let y0 = MARGIN + LINE;
        for y in 0..p.h * s {
            for x in 0..pw {
                c.put(x0 + x, y0 + y, p.rgb[(y / s) * p.w + x / s]);
            }
        }
        x0 += pw + GAP;
    }
    let mut y = MARGIN + LINE + panels_h + GAP;
    if let Some(b) = &fig.colorbar {
        c.text(MARGIN, y, &b.label);
        y += LINE;
        for x in 0..bar_w {
            let col = (b.map)(x as f64 / (bar_w - 1).max(1) as f64);
            for dy in 0..20 {
                c.put(MARGIN + x, y + dy, col);
            }
        }
        y += 20;
        // ticks at both ends and the middle
        for (t, at) in [(0.0, 0), (0.5, bar_w / 2), (1.0, bar_w - 1)] {
            for dy in 0..4 {
                c.put(MARGIN + at, y + dy, INK);
            }
            let s = tick(b.lo + t * (b.hi - b.lo));
            let tw = text_width(&s);
            let x = (MARGIN + at).saturating_sub(tw / 2).clamp(MARGIN, (MARGIN + bar_w).saturating_sub(tw));
            c.text(x, y + 4, &s);
        }
        y += 4 + LINE;
    }
    for l in &fig.caption {
        c.text(MARGIN, y, l);
        y += LINE;
    }
    crate::png::encode_rgb8(w as u32, h as u32, &c.px)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_grids_are_upscaled_to_the_minimum_and_huge_ones_capped() {
        assert_eq!(scale_of(64, 64), 8);
        assert_eq!(scale_of(100, 40), 13); // 40 · 13 = 520 ≥ 512
        assert_eq!(scale_of(2000, 10), 2); // 2000 · 2 ≤ 4096 < 2000 · 3
        assert_eq!(scale_of(600, 600), 1);
    }

    #[test]
    fn a_triptych_of_a_small_grid_renders_three_512_px_panels_with_bar_and_caption() {
        let p = |t: &str| Panel::from_fn(t, 64, 64, |i, j| [(4 * i) as u8, (4 * j) as u8, 0]);
        let fig = Figure {
            panels: vec![p("runtime"), p("reference"), p("difference")],
            colorbar: Some(ColorBar { label: "x".into(), lo: -1.0, hi: 1.0, map: diverging }),
            caption: vec!["NRMSE 0.0123".into(), "settings".into()],
        };
        let png = render(&fig);
        let dim = |o: usize| u32::from_be_bytes(png[o..o + 4].try_into().unwrap()) as usize;
        assert_eq!(dim(16), 2 * MARGIN + 3 * 512 + 2 * GAP);
        assert_eq!(dim(20), MARGIN + LINE + 512 + GAP + (LINE + 24 + LINE) + 2 * LINE + MARGIN);
    }

    #[test]
    fn ticks_keep_three_significant_digits() {
        assert_eq!(tick(0.0), "0");
        assert_eq!(tick(0.1234), "0.123");
        assert_eq!(tick(-12.345), "-12.3");
        assert_eq!(tick(250.0), "250");
        assert_eq!(tick(2.5e-5), "2.50e-5");
    }

    #[test]
    fn the_diverging_map_is_white_at_zero_and_saturates_at_the_ends() {
        assert_eq!(diverging(0.5), [255, 255, 255]);
        assert_eq!(diverging(1.0), [255, 0, 0]);
        assert_eq!(diverging(0.0), [0, 0, 255]);
    }

    #[test]
    fn glyphs_are_drawn_left_to_right_and_top_down() {
        // "L": the stroke is on the left, the foot on the bottom row
        let mut c = Canvas { w: 16, h: 16, px: vec![0; 16 * 16 * 3] };
        c.text(0, 0, "L");
        let on = |x: usize, y: usize| c.px[(y * 16 + x) * 3] == INK[0];
        let left: usize = (0..8).map(|y| (0..8).filter(|&x| on(x, 2 * y)).count()).sum();
        let right: usize = (0..8).map(|y| (8..16).filter(|&x| on(x, 2 * y)).count()).sum();
        assert!(left > right, "{left} {right}");
        let top: usize = (0..16).filter(|&x| on(x, 0)).count();
        let foot: usize = (0..16).filter(|&x| on(x, 12)).count();
        assert!(foot > top, "{foot} {top}");
    }
}
