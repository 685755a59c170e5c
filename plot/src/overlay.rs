//! Marks drawn over a picture (a camera frame): crosses, circles and labels in its pixels.

use crate::canvas::render_over;
use crate::error::PlotError;
use crate::font;
use crate::palette::Colour;
use image::RgbImage;
use plotters::element::{Circle, PathElement, Rectangle, Text};
use plotters::style::{Color, RGBColor, ShapeStyle};

/// A mark in the picture's pixels (x right, y down).
#[derive(Debug, Clone, PartialEq)]
pub enum Mark {
    /// A cross with arms `arm` px long each way.
    Cross {
        centre: [f64; 2],
        arm: f64,
        colour: Colour,
    },
    /// A circle of `radius` px.
    Circle {
        centre: [f64; 2],
        radius: f64,
        colour: Colour,
    },
    /// A line of text with its top-left corner at `at`, on a dark box.
    Label {
        at: [f64; 2],
        text: String,
        colour: Colour,
    },
}

fn px(v: f64) -> i32 {
    if v.is_finite() {
        v.round().clamp(-1e6, 1e6) as i32
    } else {
        -1_000_000
    }
}

/// `picture` with `marks` drawn over it (lines 2 px wide).
pub fn overlay(picture: &RgbImage, marks: &[Mark]) -> Result<RgbImage, PlotError> {
    let label_px = (f64::from(picture.height()) / 45.0).clamp(14.0, 28.0);
    render_over(picture.clone(), |root| {
        for m in marks {
            match m {
                Mark::Cross {
                    centre,
                    arm,
                    colour,
                } => {
                    let style =
                        ShapeStyle::from(RGBColor(colour[0], colour[1], colour[2])).stroke_width(2);
                    let (x, y, a) = (px(centre[0]), px(centre[1]), px(*arm));
                    root.draw(&PathElement::new(vec![(x - a, y), (x + a, y)], style))?;
                    root.draw(&PathElement::new(vec![(x, y - a), (x, y + a)], style))?;
                }
                Mark::Circle {
                    centre,
                    radius,
                    colour,
                } => {
                    let style =
                        ShapeStyle::from(RGBColor(colour[0], colour[1], colour[2])).stroke_width(2);
                    let r = radius.clamp(0.0, 1e6).round() as u32;
                    root.draw(&Circle::new((px(centre[0]), px(centre[1])), r, style))?;
                }
                Mark::Label { at, text, colour } => {
                    let style = font::text(label_px, *colour);
                    let (w, h) = root.estimate_text_size(text, &style)?;
                    let (x, y) = (px(at[0]), px(at[1]));
                    root.draw(&Rectangle::new(
                        [(x - 6, y - 4), (x + w as i32 + 6, y + h as i32 + 6)],
                        RGBColor(0, 0, 0).mix(0.7).filled(),
                    ))?;
                    root.draw(&Text::new(text.clone(), (x, y), style))?;
                }
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marks_land_on_the_picture_and_leave_the_rest() {
        let frame = RgbImage::from_pixel(200, 100, image::Rgb([20, 20, 40]));
        let out = overlay(
            &frame,
            &[
                Mark::Cross {
                    centre: [50.0, 50.0],
                    arm: 10.0,
                    colour: [255, 255, 0],
                },
                Mark::Circle {
                    centre: [50.0, 50.0],
                    radius: 30.0,
                    colour: [255, 255, 0],
                },
            ],
        )
        .expect("draws");
        assert_eq!(out.dimensions(), (200, 100));
        assert_eq!(out.get_pixel(50, 45).0, [255, 255, 0], "the cross");
        assert_eq!(
            out.get_pixel(150, 50).0,
            [20, 20, 40],
            "the frame elsewhere"
        );
        assert!(
            out.pixels().filter(|p| p.0 == [255, 255, 0]).count() > 150,
            "the circle"
        );
    }
}
