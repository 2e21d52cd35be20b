//! Charts drawn once and written as PNG or SVG: the drawing is a list of
//! shapes in pixel coordinates, rasterised with embedded-graphics' mono
//! fonts for a PNG and written as SVG elements for an SVG.

use std::fmt::Write as _;
use std::io::BufWriter;
use std::path::Path;

use embedded_graphics::mono_font::ascii::{FONT_7X13, FONT_9X15_BOLD};
use embedded_graphics::mono_font::MonoTextStyle;
use embedded_graphics::pixelcolor::Rgb888;
use embedded_graphics::prelude::*;
use embedded_graphics::primitives::{Circle, Line, PrimitiveStyle, Rectangle};
use embedded_graphics::text::Text;

pub use embedded_graphics::pixelcolor::Rgb888 as Colour;
pub use embedded_graphics::prelude::{Point, Size};
pub use embedded_graphics::text::Alignment;

pub const BLACK: Colour = Colour::new(0, 0, 0);
pub const GRID: Colour = Colour::new(235, 235, 235);

enum Shape {
    Line(Point, Point, Colour, u32),
    Rect(Point, Size, Colour),
    /// A filled disc of diameter `d` centred on the point, outlined or not.
    Disc(Point, u32, Colour, bool),
    /// Text at its baseline; bold for titles.
    Text(String, Point, Alignment, bool),
}

/// A drawing `w` by `h` pixels on white.
pub struct Chart {
    w: u32,
    h: u32,
    shapes: Vec<Shape>,
}

impl Chart {
    pub fn new(w: u32, h: u32) -> Chart {
        Chart {
            w,
            h,
            shapes: Vec::new(),
        }
    }

    pub fn text(&mut self, s: &str, at: Point, align: Alignment) {
        self.shapes
            .push(Shape::Text(s.to_string(), at, align, false));
    }

    pub fn title(&mut self, s: &str, at: Point) {
        self.shapes
            .push(Shape::Text(s.to_string(), at, Alignment::Left, true));
    }

    pub fn line(&mut self, a: Point, b: Point, c: Colour, w: u32) {
        self.shapes.push(Shape::Line(a, b, c, w));
    }

    pub fn rect(&mut self, at: Point, size: Size, c: Colour) {
        self.shapes.push(Shape::Rect(at, size, c));
    }

    /// A disc outlined in black, for places (ends, home).
    pub fn marker(&mut self, centre: Point, d: u32, c: Colour) {
        self.shapes.push(Shape::Disc(centre, d, c, true));
    }

    /// A disc without outline.
    pub fn disc(&mut self, centre: Point, d: u32, c: Colour) {
        self.shapes.push(Shape::Disc(centre, d, c, false));
    }

    /// A panel's x and y axes for the plot area whose top-left corner is
    /// (`left`, `top`), `pw` by `ph` px, each named at its end.
    pub fn axes(&mut self, (left, top): (i32, i32), pw: i32, ph: i32, x_name: &str, y_name: &str) {
        let bottom = top + ph;
        self.line(
            Point::new(left, bottom),
            Point::new(left + pw, bottom),
            BLACK,
            1,
        );
        self.line(Point::new(left, top), Point::new(left, bottom), BLACK, 1);
        self.text(x_name, Point::new(left + pw, bottom + 33), Alignment::Right);
        self.text(y_name, Point::new(left - 6, top - 24), Alignment::Right);
    }

    /// A legend row: swatches with their labels, from `x`.
    pub fn legend(&mut self, mut x: i32, y: i32, items: &[(Colour, String)]) {
        for (colour, label) in items {
            self.marker(Point::new(x + 6, y - 4), 11, *colour);
            self.text(label, Point::new(x + 16, y), Alignment::Left);
            x += 16 + 7 * label.len() as i32 + 22;
        }
    }

    /// Write the chart as PNG or SVG, as `path`'s extension says.
    pub fn save(&self, path: &Path) -> Result<(), String> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
        match ext.as_deref() {
            Some("png") => {
                let file = std::fs::File::create(path).map_err(|e| err(&e))?;
                let mut enc = png::Encoder::new(BufWriter::new(file), self.w, self.h);
                enc.set_color(png::ColorType::Rgb);
                enc.set_depth(png::BitDepth::Eight);
                enc.write_header()
                    .and_then(|mut w| w.write_image_data(&self.raster()))
                    .map_err(|e| err(&e))
            }
            Some("svg") => std::fs::write(path, self.svg()).map_err(|e| err(&e)),
            _ => Err(format!(
                "{}: a plot is written as .png or .svg",
                path.display()
            )),
        }
    }

    /// The chart as RGB pixels, row by row.
    pub fn raster(&self) -> Vec<u8> {
        let mut c = Raster {
            w: self.w,
            h: self.h,
            rgb: vec![255; (self.w * self.h * 3) as usize],
        };
        for s in &self.shapes {
            match s {
                Shape::Line(a, b, col, w) => {
                    let _ = Line::new(*a, *b)
                        .into_styled(PrimitiveStyle::with_stroke(*col, *w))
                        .draw(&mut c);
                }
                Shape::Rect(at, size, col) => {
                    let _ = Rectangle::new(*at, *size)
                        .into_styled(PrimitiveStyle::with_fill(*col))
                        .draw(&mut c);
                }
                Shape::Disc(centre, d, col, outline) => {
                    let at = *centre - Point::new(*d as i32 / 2, *d as i32 / 2);
                    let _ = Circle::new(at, *d)
                        .into_styled(PrimitiveStyle::with_fill(*col))
                        .draw(&mut c);
                    if *outline {
                        let _ = Circle::new(at, *d)
                            .into_styled(PrimitiveStyle::with_stroke(BLACK, 1))
                            .draw(&mut c);
                    }
                }
                Shape::Text(s, at, align, bold) => {
                    let font = if *bold { &FONT_9X15_BOLD } else { &FONT_7X13 };
                    let style = MonoTextStyle::new(font, BLACK);
                    let _ = Text::with_alignment(s, *at, style, *align).draw(&mut c);
                }
            }
        }
        c.rgb
    }

    /// The chart as an SVG document.
    pub fn svg(&self) -> String {
        let rgb = |c: &Colour| format!("#{:02x}{:02x}{:02x}", c.r(), c.g(), c.b());
        let mut out = String::new();
        let _ = write!(
            out,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" font-family=\"monospace\">\n<rect width=\"{w}\" height=\"{h}\" fill=\"#ffffff\"/>\n",
            w = self.w,
            h = self.h
        );
        for s in &self.shapes {
            let _ = match s {
                Shape::Line(a, b, col, w) => writeln!(
                    out,
                    "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"{}\" stroke-width=\"{w}\"/>",
                    a.x, a.y, b.x, b.y, rgb(col)
                ),
                Shape::Rect(at, size, col) => writeln!(
                    out,
                    "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{}\"/>",
                    at.x, at.y, size.width, size.height, rgb(col)
                ),
                Shape::Disc(centre, d, col, outline) => writeln!(
                    out,
                    "<circle cx=\"{}\" cy=\"{}\" r=\"{}\" fill=\"{}\"{}/>",
                    centre.x,
                    centre.y,
                    *d as f64 / 2.0,
                    rgb(col),
                    if *outline { " stroke=\"#000000\"" } else { "" }
                ),
                Shape::Text(s, at, align, bold) => writeln!(
                    out,
                    "<text x=\"{}\" y=\"{}\" font-size=\"{}\"{} text-anchor=\"{}\">{}</text>",
                    at.x,
                    at.y,
                    if *bold { 15 } else { 13 },
                    if *bold { " font-weight=\"bold\"" } else { "" },
                    match align {
                        Alignment::Left => "start",
                        Alignment::Center => "middle",
                        Alignment::Right => "end",
                    },
                    escape(s)
                ),
            };
        }
        out.push_str("</svg>\n");
        out
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// A round step for axis ticks: about `n` over `span`.
pub fn tick_step(span: f64, n: f64) -> f64 {
    let raw = (span / n).max(1e-9);
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag)
}

struct Raster {
    w: u32,
    h: u32,
    rgb: Vec<u8>,
}

impl OriginDimensions for Raster {
    fn size(&self) -> Size {
        Size::new(self.w, self.h)
    }
}

impl DrawTarget for Raster {
    type Color = Rgb888;
    type Error = core::convert::Infallible;

    fn draw_iter<I: IntoIterator<Item = Pixel<Rgb888>>>(
        &mut self,
        px: I,
    ) -> Result<(), Self::Error> {
        for Pixel(p, c) in px {
            if p.x >= 0 && p.y >= 0 && (p.x as u32) < self.w && (p.y as u32) < self.h {
                let i = 3 * (p.y as usize * self.w as usize + p.x as usize);
                self.rgb[i..i + 3].copy_from_slice(&[c.r(), c.g(), c.b()]);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_drawing_gives_a_png_and_an_svg_and_other_names_are_refused() {
        let dir = tempfile::tempdir().expect("tmp");
        let mut c = Chart::new(120, 80);
        c.title("a <title> & more", Point::new(5, 15));
        c.rect(
            Point::new(10, 20),
            Size::new(30, 30),
            Colour::new(200, 0, 0),
        );
        c.marker(Point::new(80, 40), 11, Colour::new(0, 150, 0));
        c.save(&dir.path().join("c.png")).expect("png");
        let png = std::fs::read(dir.path().join("c.png")).expect("read");
        assert_eq!(&png[1..4], b"PNG");
        // The red square is in the raster where it was drawn.
        let r = c.raster();
        let at = 3 * (30 * 120 + 20);
        assert_eq!(&r[at..at + 3], &[200, 0, 0]);
        c.save(&dir.path().join("c.svg")).expect("svg");
        let svg = std::fs::read_to_string(dir.path().join("c.svg")).expect("read");
        assert!(svg.starts_with("<svg"), "{svg}");
        assert!(svg.contains("a &lt;title&gt; &amp; more"), "{svg}");
        assert!(svg.contains("fill=\"#c80000\""), "{svg}");
        let e = c.save(&dir.path().join("c.jpg")).expect_err("jpg");
        assert!(e.contains(".png or .svg"), "{e}");
    }

    #[test]
    fn ticks_are_round() {
        assert_eq!(tick_step(100.0, 10.0), 10.0);
        assert_eq!(tick_step(37.0, 12.0), 5.0);
        assert_eq!(tick_step(0.9, 5.0), 0.2);
    }
}
