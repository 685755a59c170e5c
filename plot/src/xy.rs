//! A chart over two numeric axes: lines, points, segments, arrows, rings, circles and labels in
//! data coordinates, with a title, labelled axes, round ticks, a legend and notes.

use crate::canvas::{render, Area};
use crate::error::PlotError;
use crate::font;
use crate::palette::Colour;
use crate::palette::{BLACK, LIGHT_GREY, WHITE};
use crate::ticks;
use image::RgbImage;
use plotters::chart::{ChartBuilder, ChartContext, SeriesLabelPosition};
use plotters::coord::cartesian::Cartesian2d;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::element::{
    Circle, DashedPathElement, EmptyElement, PathElement, Polygon, Rectangle, Text,
};
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{Color, RGBColor, ShapeStyle};

type Coord = Cartesian2d<Ticked, Ticked>;

/// A numeric axis from `lo` to `hi` with its ticks (and grid lines) at `ticks`.
#[derive(Debug, Clone)]
pub(crate) struct Ticked {
    pub(crate) lo: f64,
    pub(crate) hi: f64,
    pub(crate) ticks: Vec<f64>,
}

impl Ranged for Ticked {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let t = (v - self.lo) / (self.hi - self.lo);
        let px = f64::from(limit.0) + t * f64::from(limit.1 - limit.0);
        if px.is_finite() {
            px.round().clamp(-1e7, 1e7) as i32
        } else {
            limit.0
        }
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.lo..self.hi
    }
}
type Context<'a, 'b> = ChartContext<'a, plotters::backend::BitMapBackend<'b>, Coord>;

const TITLE_PX: f64 = 21.0;
const AXIS_PX: f64 = 18.0;
const TICK_PX: f64 = 15.0;
const LEGEND_PX: f64 = 15.0;

fn rgb(c: Colour) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// One axis: its label with the unit ("measured Fz (N)"), its range (from the data when not
/// given) and its ticks.
#[derive(Debug, Clone)]
pub struct Axis {
    label: String,
    range: Option<[f64; 2]>,
    integers: bool,
    from_zero: bool,
    dates: bool,
}

impl Axis {
    /// An axis labelled `label` (name and unit), its range from the data.
    pub fn new(label: impl Into<String>) -> Axis {
        Axis {
            label: label.into(),
            range: None,
            integers: false,
            from_zero: false,
            dates: false,
        }
    }

    /// Dates: values are days since 1970-01-01 (UTC, fractions for the time of day), ticks fall
    /// on whole days labelled `YYYY-MM-DD`, and the data of a single day sits in the middle.
    pub fn dates(mut self) -> Axis {
        self.dates = true;
        self
    }

    /// Shows `lo` to `hi`.
    pub fn range(mut self, lo: f64, hi: f64) -> Axis {
        self.range = Some([lo, hi]);
        self
    }

    /// Counts (checks, epochs, presses): ticks at whole numbers only, and every value half a
    /// step inside the border.
    pub fn integers(mut self) -> Axis {
        self.integers = true;
        self
    }

    /// The range reaches down to zero.
    pub fn from_zero(mut self) -> Axis {
        self.from_zero = true;
        self
    }
}

/// Where a legend or the notes sit inside the plotting area.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Corner {
    UpperLeft,
    UpperRight,
    LowerLeft,
    LowerRight,
}

#[derive(Debug, Clone)]
enum Shape {
    /// Points joined in order; with markers at the points when `markers`.
    Line {
        points: Vec<[f64; 2]>,
        markers: bool,
        dashed: bool,
    },
    /// Filled discs of `radius` px.
    Points { points: Vec<[f64; 2]>, radius: u32 },
    /// Filled discs of `radius` px, each in its own colour, outlined in black.
    ColouredPoints {
        points: Vec<([f64; 2], Colour)>,
        radius: u32,
    },
    /// Straight segments from the first point to the second.
    Segments { pairs: Vec<[[f64; 2]; 2]> },
    /// Segments with a head at the second point.
    Arrows { pairs: Vec<[[f64; 2]; 2]> },
    /// Rings of `radius` px about each point.
    Rings { centres: Vec<[f64; 2]>, radius: u32 },
    /// A circle in data units.
    Circle { centre: [f64; 2], radius: f64 },
    /// Text just below and right of each point.
    Labels { items: Vec<([f64; 2], String)> },
}

/// A named set of marks in one colour; a series with a name gets a legend entry.
#[derive(Debug, Clone)]
pub struct Series {
    name: String,
    colour: Colour,
    shape: Shape,
}

impl Series {
    fn new(name: impl Into<String>, colour: Colour, shape: Shape) -> Series {
        Series {
            name: name.into(),
            colour,
            shape,
        }
    }

    /// `points` joined by a line (`name` empty: no legend entry).
    pub fn line(name: impl Into<String>, points: &[[f64; 2]], colour: Colour) -> Series {
        let shape = Shape::Line {
            points: points.to_vec(),
            markers: false,
            dashed: false,
        };
        Series::new(name, colour, shape)
    }

    /// `points` as filled discs of `radius` px.
    pub fn points(
        name: impl Into<String>,
        points: &[[f64; 2]],
        radius: u32,
        colour: Colour,
    ) -> Series {
        let shape = Shape::Points {
            points: points.to_vec(),
            radius,
        };
        Series::new(name, colour, shape)
    }

    /// Discs each in its own colour (a value shown by colour; add [`Series::key`]s for the legend).
    pub fn coloured_points(points: &[([f64; 2], Colour)], radius: u32) -> Series {
        let shape = Shape::ColouredPoints {
            points: points.to_vec(),
            radius,
        };
        Series::new("", BLACK, shape)
    }

    /// A legend entry alone: a disc of `colour` and its meaning.
    pub fn key(name: impl Into<String>, colour: Colour) -> Series {
        Series::new(
            name,
            colour,
            Shape::Points {
                points: Vec::new(),
                radius: 6,
            },
        )
    }

    /// A segment for each pair, first point to second.
    pub fn segments(name: impl Into<String>, pairs: &[[[f64; 2]; 2]], colour: Colour) -> Series {
        Series::new(
            name,
            colour,
            Shape::Segments {
                pairs: pairs.to_vec(),
            },
        )
    }

    /// An arrow for each pair, from the first point to the second.
    pub fn arrows(name: impl Into<String>, pairs: &[[[f64; 2]; 2]], colour: Colour) -> Series {
        Series::new(
            name,
            colour,
            Shape::Arrows {
                pairs: pairs.to_vec(),
            },
        )
    }

    /// A ring of `radius` px about each point.
    pub fn rings(
        name: impl Into<String>,
        centres: &[[f64; 2]],
        radius: u32,
        colour: Colour,
    ) -> Series {
        let shape = Shape::Rings {
            centres: centres.to_vec(),
            radius,
        };
        Series::new(name, colour, shape)
    }

    /// A circle of `radius` (data units) about `centre`.
    pub fn circle(
        name: impl Into<String>,
        centre: [f64; 2],
        radius: f64,
        colour: Colour,
    ) -> Series {
        Series::new(name, colour, Shape::Circle { centre, radius })
    }

    /// Each text beside its point.
    pub fn labels(items: &[([f64; 2], String)], colour: Colour) -> Series {
        Series::new(
            "",
            colour,
            Shape::Labels {
                items: items.to_vec(),
            },
        )
    }

    /// A line's points marked with discs too.
    pub fn with_markers(mut self) -> Series {
        if let Shape::Line { markers, .. } = &mut self.shape {
            *markers = true;
        }
        self
    }

    /// A line drawn dashed (thresholds, references).
    pub fn dashed(mut self) -> Series {
        if let Shape::Line { dashed, .. } = &mut self.shape {
            *dashed = true;
        }
        self
    }

    /// The data points the series needs to show, for the automatic ranges.
    fn extent(&self) -> Vec<[f64; 2]> {
        match &self.shape {
            Shape::Line { points, .. } | Shape::Points { points, .. } => points.clone(),
            Shape::ColouredPoints { points, .. } => points.iter().map(|p| p.0).collect(),
            Shape::Segments { pairs } | Shape::Arrows { pairs } => {
                pairs.iter().flat_map(|p| [p[0], p[1]]).collect()
            }
            Shape::Rings { centres, .. } => centres.clone(),
            Shape::Circle { centre, radius } => vec![
                [centre[0] - radius, centre[1] - radius],
                [centre[0] + radius, centre[1] + radius],
            ],
            Shape::Labels { items } => items.iter().map(|i| i.0).collect(),
        }
    }
}

/// A chart: title, two axes, series, notes.
#[derive(Debug, Clone)]
pub struct Chart {
    title: String,
    x: Axis,
    y: Axis,
    series: Vec<Series>,
    notes: Vec<String>,
    notes_at: Corner,
    legend_at: Corner,
    equal_aspect: bool,
}

fn finite(p: &[f64; 2]) -> bool {
    p[0].is_finite() && p[1].is_finite()
}

fn to_xy(p: &[f64; 2]) -> (f64, f64) {
    (p[0], p[1])
}

impl Chart {
    /// A chart titled `title` over axes `x` and `y`.
    pub fn new(title: impl Into<String>, x: Axis, y: Axis) -> Chart {
        Chart {
            title: title.into(),
            x,
            y,
            series: Vec::new(),
            notes: Vec::new(),
            notes_at: Corner::UpperLeft,
            legend_at: Corner::UpperRight,
            equal_aspect: false,
        }
    }

    /// Adds a series (drawn in the order added).
    pub fn series(mut self, s: Series) -> Chart {
        self.series.push(s);
        self
    }

    /// Adds a line of text in a box inside the plot (figures such as an RMSE).
    pub fn note(mut self, line: impl Into<String>) -> Chart {
        self.notes.push(line.into());
        self
    }

    /// Where the notes go (upper left unless told).
    pub fn notes_at(mut self, corner: Corner) -> Chart {
        self.notes_at = corner;
        self
    }

    /// Where the legend goes (upper right unless told).
    pub fn legend_at(mut self, corner: Corner) -> Chart {
        self.legend_at = corner;
        self
    }

    /// One unit is as long on x as on y (maps, positions in mm).
    pub fn equal_aspect(mut self) -> Chart {
        self.equal_aspect = true;
        self
    }

    /// The chart as a `width` x `height` picture.
    pub fn render(&self, width: u32, height: u32) -> Result<RgbImage, PlotError> {
        render(width, height, |root| self.draw_on(root))
    }

    /// The ranges shown: given, or the data's padded by 5 % (half a step for counts).
    fn ranges(&self) -> ([f64; 2], [f64; 2]) {
        let pts: Vec<[f64; 2]> = self
            .series
            .iter()
            .flat_map(Series::extent)
            .filter(finite)
            .collect();
        let range = |axis: &Axis, k: usize| -> [f64; 2] {
            if let Some(r) = axis.range {
                return r;
            }
            let mut lo = pts.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min);
            let mut hi = pts.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max);
            if !(lo.is_finite() && hi.is_finite()) {
                (lo, hi) = (0.0, 1.0);
            }
            if axis.from_zero {
                lo = lo.min(0.0);
                hi = hi.max(0.0);
            }
            if axis.integers {
                return [lo.floor() - 0.5, hi.ceil() + 0.5];
            }
            if axis.dates {
                if hi - lo < 1.0 {
                    let mid = 0.5 * (lo + hi);
                    return [mid - 1.0, mid + 1.0];
                }
                let pad = (0.08 * (hi - lo)).max(0.5);
                return [lo - pad, hi + pad];
            }
            if hi - lo < 1e-9 * (1.0 + lo.abs()) {
                let d = (0.1 * lo.abs()).max(1e-3);
                return [lo - d, hi + d];
            }
            let pad = 0.05 * (hi - lo);
            let lo = if axis.from_zero && lo >= 0.0 {
                lo
            } else {
                lo - pad
            };
            [lo, hi + pad]
        };
        let mut y = range(&self.y, 1);
        // Room at the top for a legend in an upper corner, so that it hides no data.
        let legend_above = matches!(self.legend_at, Corner::UpperLeft | Corner::UpperRight);
        if self.y.range.is_none() && legend_above && self.series.iter().any(|s| !s.name.is_empty())
        {
            y[1] += 0.25 * (y[1] - y[0]);
        }
        (range(&self.x, 0), y)
    }

    /// The chart drawn over `area`.
    pub(crate) fn draw_on(&self, area: &Area<'_>) -> Result<(), PlotError> {
        area.fill(&rgb(WHITE))?;
        let (mut xr, mut yr) = self.ranges();
        if self.equal_aspect {
            let (w, h) = {
                let ctx = self.context(area, xr, yr)?;
                ctx.plotting_area().dim_in_pixel()
            };
            (xr, yr) = equalise(xr, yr, f64::from(w.max(1)), f64::from(h.max(1)));
            area.fill(&rgb(WHITE))?;
        }
        let mut ctx = self.context(area, xr, yr)?;
        let x_dec = ticks::decimals(tick_step(&self.x, xr));
        let y_dec = ticks::decimals(tick_step(&self.y, yr));
        let x_fmt = |v: &f64| tick_label(&self.x, *v, x_dec);
        let y_fmt = |v: &f64| tick_label(&self.y, *v, y_dec);
        ctx.configure_mesh()
            .x_desc(self.x.label.as_str())
            .y_desc(self.y.label.as_str())
            .axis_desc_style(font::text(AXIS_PX, BLACK))
            .label_style(font::text(TICK_PX, BLACK))
            .bold_line_style(rgb(LIGHT_GREY))
            .axis_style(rgb(BLACK))
            .x_label_formatter(&x_fmt)
            .y_label_formatter(&y_fmt)
            .draw()?;
        let mut named = false;
        for s in &self.series {
            named |= !s.name.is_empty();
            draw_series(&mut ctx, s)?;
        }
        if named {
            ctx.configure_series_labels()
                .position(legend_position(self.legend_at))
                .background_style(rgb(WHITE).mix(0.9))
                .border_style(rgb(BLACK))
                .label_font(font::text(LEGEND_PX, BLACK))
                .margin(10)
                .draw()?;
        }
        self.draw_notes(&ctx)?;
        Ok(())
    }

    /// The chart's frame over `area`: title, label areas and the coordinates.
    fn context<'a, 'b>(
        &self,
        area: &'a Area<'b>,
        xr: [f64; 2],
        yr: [f64; 2],
    ) -> Result<Context<'a, 'b>, PlotError> {
        let xt = ticks::values(xr[0], xr[1], tick_step(&self.x, xr));
        let yt = ticks::values(yr[0], yr[1], tick_step(&self.y, yr));
        let y_label_px = yt
            .iter()
            .map(|v| ticks::label(*v, ticks::decimals(tick_step(&self.y, yr))).len())
            .max()
            .unwrap_or(1) as u32
            * 9
            + 44;
        let mut builder = ChartBuilder::on(area);
        builder
            .margin(14)
            .margin_right(24)
            .x_label_area_size(52)
            .y_label_area_size(y_label_px);
        if !self.title.is_empty() {
            builder.caption(self.title.as_str(), font::text(TITLE_PX, BLACK));
        }
        Ok(builder.build_cartesian_2d(
            Ticked {
                lo: xr[0],
                hi: xr[1],
                ticks: xt,
            },
            Ticked {
                lo: yr[0],
                hi: yr[1],
                ticks: yt,
            },
        )?)
    }

    /// The notes, one a line, in a white box in their corner of the plotting area.
    fn draw_notes(&self, ctx: &Context<'_, '_>) -> Result<(), PlotError> {
        if self.notes.is_empty() {
            return Ok(());
        }
        let area = ctx.plotting_area().strip_coord_spec();
        let (w, h) = area.dim_in_pixel();
        let style = font::text(LEGEND_PX, BLACK);
        let line_px = 20;
        let text_w = self
            .notes
            .iter()
            .map(|n| area.estimate_text_size(n, &style).map(|s| s.0))
            .collect::<Result<Vec<u32>, _>>()?
            .into_iter()
            .max()
            .unwrap_or(0) as i32;
        let box_w = text_w + 16;
        let box_h = line_px * self.notes.len() as i32 + 10;
        let x0 = match self.notes_at {
            Corner::UpperLeft | Corner::LowerLeft => 10,
            Corner::UpperRight | Corner::LowerRight => w as i32 - 10 - box_w,
        };
        let y0 = match self.notes_at {
            Corner::UpperLeft | Corner::UpperRight => 10,
            Corner::LowerLeft | Corner::LowerRight => h as i32 - 10 - box_h,
        };
        area.draw(&Rectangle::new(
            [(x0, y0), (x0 + box_w, y0 + box_h)],
            rgb(WHITE).mix(0.9).filled(),
        ))?;
        area.draw(&Rectangle::new(
            [(x0, y0), (x0 + box_w, y0 + box_h)],
            rgb(BLACK),
        ))?;
        for (k, n) in self.notes.iter().enumerate() {
            area.draw(&Text::new(
                n.clone(),
                (x0 + 8, y0 + 6 + line_px * k as i32),
                style.clone(),
            ))?;
        }
        Ok(())
    }
}

/// A tick's label: a date on a date axis, else the value with `decimals`.
fn tick_label(axis: &Axis, v: f64, decimals: usize) -> String {
    if axis.dates {
        ticks::date(v)
    } else {
        ticks::label(v, decimals)
    }
}

/// The tick step of `axis` over `range`: about six round ticks, whole numbers for counts, whole
/// days (about four: a date is a long label) for dates.
fn tick_step(axis: &Axis, range: [f64; 2]) -> f64 {
    if axis.dates {
        return ticks::step(range[1] - range[0], 4.0).round().max(1.0);
    }
    let s = ticks::step(range[1] - range[0], 6.0);
    if axis.integers {
        s.round().max(1.0)
    } else {
        s
    }
}

/// Ranges widened so that a unit spans as many px on x as on y over a `w` x `h` px area.
fn equalise(xr: [f64; 2], yr: [f64; 2], w: f64, h: f64) -> ([f64; 2], [f64; 2]) {
    let per_px = ((xr[1] - xr[0]) / w).max((yr[1] - yr[0]) / h);
    let widen = |r: [f64; 2], px: f64| {
        let (mid, half) = (0.5 * (r[0] + r[1]), 0.5 * per_px * px);
        [mid - half, mid + half]
    };
    (widen(xr, w), widen(yr, h))
}

fn legend_position(c: Corner) -> SeriesLabelPosition {
    match c {
        Corner::UpperLeft => SeriesLabelPosition::UpperLeft,
        Corner::UpperRight => SeriesLabelPosition::UpperRight,
        Corner::LowerLeft => SeriesLabelPosition::LowerLeft,
        Corner::LowerRight => SeriesLabelPosition::LowerRight,
    }
}

/// A legend entry only for a series with a name (plotters lists any series given a glyph).
trait LegendIf<'a, DB: plotters::backend::DrawingBackend + 'a> {
    fn legend_if<E, F>(&mut self, named: bool, glyph: F) -> &mut Self
    where
        E: plotters::element::IntoDynElement<'a, DB, (i32, i32)>,
        F: Fn((i32, i32)) -> E + 'a;
}

impl<'a, DB: plotters::backend::DrawingBackend + 'a> LegendIf<'a, DB>
    for plotters::chart::SeriesAnno<'a, DB>
{
    fn legend_if<E, F>(&mut self, named: bool, glyph: F) -> &mut Self
    where
        E: plotters::element::IntoDynElement<'a, DB, (i32, i32)>,
        F: Fn((i32, i32)) -> E + 'a,
    {
        if named {
            self.legend(glyph)
        } else {
            self
        }
    }
}

/// Draws `s` and, when it has a name, gives it its legend entry.
fn draw_series<'a, 'b: 'a>(ctx: &mut Context<'a, 'b>, s: &Series) -> Result<(), PlotError> {
    let colour = rgb(s.colour);
    let stroke = ShapeStyle::from(colour).stroke_width(2);
    let named = !s.name.is_empty();
    let anno = match &s.shape {
        Shape::Line {
            points,
            markers,
            dashed,
        } => {
            let pts: Vec<(f64, f64)> = points.iter().filter(|p| finite(p)).map(to_xy).collect();
            if *markers {
                ctx.draw_series(pts.iter().map(|p| Circle::new(*p, 4, colour.filled())))?;
            }
            let anno = if *dashed {
                ctx.draw_series(std::iter::once(DashedPathElement::new(
                    pts.clone(),
                    8,
                    6,
                    stroke,
                )))?
            } else {
                ctx.draw_series(std::iter::once(PathElement::new(pts, stroke)))?
            };
            // One shape of legend glyph for every line: two dashes (one long one for a solid
            // line) and a marker (invisible without markers).
            let (first, second) = if *dashed { (9, 15) } else { (24, 24) };
            let marker = if *markers {
                colour.filled()
            } else {
                colour.mix(0.0).filled()
            };
            anno.legend_if(named, move |(x, y)| {
                EmptyElement::at((x, y))
                    + PathElement::new(vec![(0, 0), (first, 0)], stroke)
                    + PathElement::new(vec![(second, 0), (24, 0)], stroke)
                    + Circle::new((12, 0), 4, marker)
            })
        }
        Shape::Points { points, radius } => {
            let r = *radius;
            ctx.draw_series(
                points
                    .iter()
                    .filter(|p| finite(p))
                    .map(|p| Circle::new(to_xy(p), r, colour.filled())),
            )?
            .legend_if(named, move |(x, y)| {
                Circle::new((x + 12, y), r.clamp(3, 6), colour.filled())
            })
        }
        Shape::ColouredPoints { points, radius } => {
            let r = *radius;
            ctx.draw_series(points.iter().filter(|p| finite(&p.0)).map(|(p, c)| {
                EmptyElement::at(to_xy(p))
                    + Circle::new((0, 0), r, rgb(*c).filled())
                    + Circle::new((0, 0), r, rgb(BLACK))
            }))?
        }
        Shape::Segments { pairs } => ctx
            .draw_series(
                pairs
                    .iter()
                    .filter(|p| finite(&p[0]) && finite(&p[1]))
                    .map(|p| PathElement::new(vec![to_xy(&p[0]), to_xy(&p[1])], stroke)),
            )?
            .legend_if(named, move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 24, y)], stroke)
            }),
        Shape::Arrows { pairs } => {
            let heads: Vec<_> = pairs
                .iter()
                .filter(|p| finite(&p[0]) && finite(&p[1]))
                .map(|p| {
                    let (a, b) = (
                        ctx.backend_coord(&to_xy(&p[0])),
                        ctx.backend_coord(&to_xy(&p[1])),
                    );
                    (p, head(a, b))
                })
                .collect();
            ctx.draw_series(heads.iter().map(|(p, head)| {
                EmptyElement::at(to_xy(&p[1])) + Polygon::new(head.clone(), colour.filled())
            }))?;
            ctx.draw_series(
                heads
                    .iter()
                    .map(|(p, _)| PathElement::new(vec![to_xy(&p[0]), to_xy(&p[1])], stroke)),
            )?
            .legend_if(named, move |(x, y)| {
                EmptyElement::at((x, y))
                    + PathElement::new(vec![(0, 0), (20, 0)], stroke)
                    + Polygon::new(vec![(24, 0), (15, -5), (15, 5)], colour.filled())
            })
        }
        Shape::Rings { centres, radius } => {
            let r = *radius;
            ctx.draw_series(
                centres
                    .iter()
                    .filter(|p| finite(p))
                    .map(|p| Circle::new(to_xy(p), r, stroke)),
            )?
            .legend_if(named, move |(x, y)| Circle::new((x + 12, y), 6, stroke))
        }
        Shape::Circle { centre, radius } => {
            let n = 240;
            let pts: Vec<(f64, f64)> = (0..=n)
                .map(|k| {
                    let a = std::f64::consts::TAU * k as f64 / n as f64;
                    (centre[0] + radius * a.cos(), centre[1] + radius * a.sin())
                })
                .collect();
            ctx.draw_series(std::iter::once(PathElement::new(pts, stroke)))?
                .legend_if(named, move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], stroke)
                })
        }
        Shape::Labels { items } => {
            ctx.draw_series(items.iter().filter(|i| finite(&i.0)).map(|(p, t)| {
                EmptyElement::at(to_xy(p))
                    + Text::new(
                        t.clone(),
                        (10, 8),
                        font::text(LEGEND_PX, s.colour).pos(Pos::new(HPos::Left, VPos::Top)),
                    )
            }))?
        }
    };
    if named {
        anno.label(s.name.as_str());
    }
    Ok(())
}

/// An arrow head's corners (px, about the tip) for a shaft from `a` to `b` (backend px).
fn head(a: (i32, i32), b: (i32, i32)) -> Vec<(i32, i32)> {
    let (dx, dy) = (f64::from(b.0 - a.0), f64::from(b.1 - a.1));
    let len = dx.hypot(dy);
    if len < 1.0 {
        return vec![(0, 0)];
    }
    let (ux, uy) = (dx / len, dy / len);
    let size = 9.0f64.min(0.6 * len).max(4.0);
    let back = |side: f64| {
        (
            (-size * ux + side * 0.5 * size * uy).round() as i32,
            (-size * uy - side * 0.5 * size * ux).round() as i32,
        )
    };
    vec![(0, 0), back(1.0), back(-1.0)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::palette::{BLUE, ORANGE};

    fn count(img: &RgbImage, c: Colour) -> usize {
        img.pixels().filter(|p| p.0 == c).count()
    }

    #[test]
    fn a_chart_draws_its_series_legend_and_labels() {
        let a = [[1.0, 2.0], [2.0, 3.0], [3.0, 2.5]];
        let b = [[1.0, 1.0], [2.0, 1.0], [3.0, 1.0]];
        let img = Chart::new(
            "Loss by epoch",
            Axis::new("epoch").integers(),
            Axis::new("loss").from_zero(),
        )
        .series(Series::line("training", &a, BLUE).with_markers())
        .series(Series::line("threshold", &b, ORANGE).dashed())
        .note("RMSE 0.1 N")
        .render(400, 300)
        .expect("draws");
        assert_eq!(img.dimensions(), (400, 300));
        assert!(count(&img, BLUE) > 50, "the line and its markers");
        assert!(count(&img, ORANGE) > 20, "the dashed line");
        // Text is anti-aliased black on white: grey levels appear.
        assert!(img
            .pixels()
            .any(|p| p.0[0] == p.0[1] && p.0[1] == p.0[2] && (60..200).contains(&p.0[0])));
    }

    #[test]
    fn a_single_count_sits_inside_the_axis_and_equal_aspect_keeps_units_square() {
        let c = Chart::new("", Axis::new("check").integers(), Axis::new("v (px)"));
        let c = c.series(Series::points("value", &[[1.0, 2.0]], 4, BLUE));
        let (x, _) = c.ranges();
        assert_eq!(x, [0.5, 1.5]);
        let (x, y) = equalise([0.0, 10.0], [0.0, 10.0], 200.0, 100.0);
        assert!(((x[1] - x[0]) / 200.0 - (y[1] - y[0]) / 100.0).abs() < 1e-12);
        assert_eq!(y, [0.0, 10.0]);
    }

    #[test]
    fn arrows_and_rings_are_drawn() {
        let img = Chart::new("", Axis::new("x (mm)"), Axis::new("y (mm)"))
            .series(Series::arrows(
                "residual",
                &[[[0.0, 0.0], [1.0, 1.0]]],
                BLUE,
            ))
            .series(Series::rings("outlier", &[[0.5, 0.5]], 9, ORANGE))
            .equal_aspect()
            .render(300, 300)
            .expect("draws");
        assert!(count(&img, BLUE) > 30);
        assert!(count(&img, ORANGE) > 30);
    }
}
