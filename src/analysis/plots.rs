//! Figures with plotters, each written as PNG and SVG. Text is drawn with the DejaVu Sans
//! font compiled into the binary (the `dejavu` crate, registered for plotters' `ab_glyph`
//! renderer): no fontconfig, FreeType or system font is needed.

use crate::compaction::{ForceLine, Particle};
use crate::pipeline::store;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

const SIZE: (u32, u32) = (900, 650);
const FONT: &str = "sans-serif";

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Line {
    Solid,
    /// Reference curves (the paper's values, analytic laws).
    Dashed,
    /// Fits.
    Dotted,
}

/// A labelled curve; `color` picks from a fixed palette (grey when None).
#[derive(Clone, Debug)]
pub struct Curve {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub line: Line,
    pub color: Option<usize>,
}

/// A value the paper states, drawn as a black cross with its label.
#[derive(Clone, Debug)]
pub struct Mark {
    pub label: String,
    pub x: f64,
    pub y: f64,
}

#[derive(Clone, Debug)]
pub struct Chart {
    /// File name without extension.
    pub stem: String,
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub curves: Vec<Curve>,
    pub marks: Vec<Mark>,
}

fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // the font is a valid TrueType file shipped in the crate
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
    });
}

fn color(k: Option<usize>) -> RGBColor {
    const PALETTE: [RGBColor; 6] = [
        RGBColor(31, 119, 180),
        RGBColor(214, 39, 40),
        RGBColor(44, 160, 44),
        RGBColor(255, 127, 14),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
    ];
    k.map_or(RGBColor(110, 110, 110), |k| PALETTE[k % PALETTE.len()])
}

/// [lo, hi] of the finite values with 4% padding (a unit span around a single value).
fn span(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if lo > hi {
        return None;
    }
    let pad = if hi > lo {
        0.04 * (hi - lo)
    } else {
        0.5 * lo.abs().max(1.0)
    };
    Some((lo - pad, hi + pad))
}

fn draw_chart<DB: DrawingBackend>(c: &Chart, root: &DrawingArea<DB, Shift>) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let xs = c.curves.iter().flat_map(|k| k.points.iter().map(|p| p.0));
    let ys = c.curves.iter().flat_map(|k| k.points.iter().map(|p| p.1));
    let (Some(xr), Some(yr)) = (
        span(xs.chain(c.marks.iter().map(|m| m.x))),
        span(ys.chain(c.marks.iter().map(|m| m.y))),
    ) else {
        return Err(format!("{}: nothing to draw", c.stem));
    };
    let mut chart = ChartBuilder::on(root)
        .caption(&c.title, (FONT, 22))
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc(&c.x_label)
        .y_desc(&c.y_label)
        .axis_desc_style((FONT, 17))
        .label_style((FONT, 14))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(e)?;
    for k in &c.curves {
        let pts: Vec<(f64, f64)> = k
            .points
            .iter()
            .copied()
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .collect();
        let style = ShapeStyle::from(color(k.color)).stroke_width(2);
        let anno = match k.line {
            Line::Solid => chart.draw_series(LineSeries::new(pts, style)),
            Line::Dashed => chart.draw_series(DashedLineSeries::new(pts, 10, 6, style)),
            Line::Dotted => chart.draw_series(DashedLineSeries::new(pts, 3, 5, style)),
        }
        .map_err(e)?;
        let dash = k.line;
        anno.label(&k.label).legend(move |(x, y)| {
            let seg = if dash == Line::Solid { 24 } else { 10 };
            PathElement::new(vec![(x, y), (x + seg, y)], style)
        });
    }
    if !c.marks.is_empty() {
        let black = ShapeStyle::from(BLACK).stroke_width(2);
        chart
            .draw_series(c.marks.iter().map(|m| Cross::new((m.x, m.y), 7, black)))
            .map_err(e)?
            .label("stated in the paper")
            .legend(move |(x, y)| Cross::new((x + 8, y), 5, black));
        chart
            .draw_series(
                c.marks.iter().map(|m| {
                    Text::new(format!("  {}", m.label), (m.x, m.y), (FONT, 13).into_font())
                }),
            )
            .map_err(e)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FONT, 14))
        .draw()
        .map_err(e)?;
    root.present().map_err(e)
}

/// The final contact-force network (paper Fig. 8g): particles as grey circles, each force
/// line with a width proportional to its force (1 to 8 px), grain-grain lines in red.
pub struct Network<'a> {
    pub stem: String,
    pub title: String,
    pub width: f64,
    pub height: f64,
    pub particles: &'a [Particle],
    pub lines: &'a [ForceLine],
}

fn draw_network<DB: DrawingBackend>(
    n: &Network,
    root: &DrawingArea<DB, Shift>,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let (w, h) = root.dim_in_pixel();
    let (margin, title) = (20.0, 40.0);
    let scale = ((w as f64 - 2.0 * margin) / n.width).min((h as f64 - title - margin) / n.height);
    let px = |p: [f64; 2]| {
        (
            (margin + p[0] * scale).round() as i32,
            (h as f64 - margin - p[1] * scale).round() as i32,
        )
    };
    root.draw(&Text::new(
        n.title.clone(),
        (margin as i32, 10),
        (FONT, 20).into_font(),
    ))
    .map_err(e)?;
    let frame = [px([0.0, 0.0]), px([n.width, n.height])];
    root.draw(&Rectangle::new(frame, BLACK.stroke_width(1)))
        .map_err(e)?;
    let grey = RGBColor(200, 200, 200);
    for p in n.particles {
        let r = (p.size * scale).round().max(1.0) as i32;
        root.draw(&Circle::new(px(p.pos), r, grey.stroke_width(1)))
            .map_err(e)?;
    }
    let f_max = n.lines.iter().map(|l| l.force).fold(0.0, f64::max);
    for l in n.lines.iter().filter(|l| l.force > 0.0) {
        let width = (1.0 + 7.0 * l.force / f_max).round() as u32;
        let c = if l.between_grains {
            RGBColor(200, 30, 30)
        } else {
            BLACK
        };
        root.draw(&PathElement::new(
            vec![px(l.a), px(l.b)],
            c.stroke_width(width),
        ))
        .map_err(e)?;
    }
    root.present().map_err(e)
}

/// Writes `stem.png` and `stem.svg` into `dir` (each atomically); returns the two names.
fn render(
    dir: &Path,
    stem: &str,
    size: (u32, u32),
    draw_png: impl Fn(&DrawingArea<BitMapBackend, Shift>) -> Result<(), String>,
    draw_svg: impl Fn(&DrawingArea<SVGBackend, Shift>) -> Result<(), String>,
) -> Result<[String; 2], String> {
    register_font();
    let png = format!("{stem}.png");
    // a temporary name that keeps the extension (the encoder goes by it) and that
    // `store::remove_temp_files` recognises
    let tmp = dir.join(format!(".{stem}.tmp-{}.png", std::process::id()));
    let drawn = {
        let root = BitMapBackend::new(&tmp, size).into_drawing_area();
        draw_png(&root)
    };
    if drawn.is_err() {
        // the backend may save what it has when dropped
        let _ = std::fs::remove_file(&tmp);
        drawn?;
    }
    std::fs::rename(&tmp, dir.join(&png)).map_err(|e| format!("{}: {e}", tmp.display()))?;
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        draw_svg(&root)?;
    }
    let svg = format!("{stem}.svg");
    store::write_atomic(&dir.join(&svg), text.as_bytes())
        .map_err(|e| format!("{}: {e}", dir.join(&svg).display()))?;
    Ok([png, svg])
}

pub fn chart(dir: &Path, c: &Chart) -> Result<[String; 2], String> {
    render(
        dir,
        &c.stem,
        SIZE,
        |r| draw_chart(c, r),
        |r| draw_chart(c, r),
    )
}

pub fn network(dir: &Path, n: &Network) -> Result<[String; 2], String> {
    // the box's aspect, 900 px across
    let h = (860.0 * n.height / n.width.max(f64::MIN_POSITIVE)).clamp(200.0, 2000.0) as u32 + 60;
    render(
        dir,
        &n.stem,
        (900, h),
        |r| draw_network(n, r),
        |r| draw_network(n, r),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chart_renders_to_png_and_svg_with_its_labels() {
        let dir = std::env::temp_dir().join(format!("softgrain-plots-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let c = Chart {
            stem: "t".into(),
            title: "Φ vs ε".into(),
            x_label: "strain ε".into(),
            y_label: "packing fraction Φ".into(),
            curves: vec![Curve {
                label: "case".into(),
                points: (0..10).map(|k| (k as f64, (k * k) as f64)).collect(),
                line: Line::Solid,
                color: Some(0),
            }],
            marks: vec![Mark {
                label: "paper".into(),
                x: 2.0,
                y: 4.0,
            }],
        };
        let names = chart(&dir, &c).unwrap();
        let png = std::fs::read(dir.join(&names[0])).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        let svg = std::fs::read_to_string(dir.join(&names[1])).unwrap();
        assert!(svg.contains("packing fraction Φ") && svg.contains("stated in the paper"));
        let empty = Chart {
            curves: vec![],
            marks: vec![],
            ..c
        };
        assert!(chart(&dir, &empty).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
