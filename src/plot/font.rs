//! The bundled font: DejaVu Sans (Bitstream Vera licence, free to embed and
//! redistribute) from the `dejavu` crate, registered once with plotters'
//! ab_glyph text renderer under the family name `sans-serif`. No system font
//! library is involved. DejaVu covers the Greek letters, primes and
//! superscript digits used in labels ("B′", "10⁻³").

use std::sync::OnceLock;

use plotters::style::{Color, FontStyle, RGBColor, TextStyle};

use crate::{Error, Result};

/// The family name every text style of this module uses.
pub const FAMILY: &str = "sans-serif";

/// Registers the bundled font (regular and bold) once per process.
pub fn ensure_font() -> Result<()> {
    static REGISTERED: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(FAMILY, FontStyle::Normal, dejavu::sans::regular())
                .map_err(|_| "the bundled DejaVu Sans regular font did not parse".to_string())?;
            plotters::style::register_font(FAMILY, FontStyle::Bold, dejavu::sans::bold())
                .map_err(|_| "the bundled DejaVu Sans bold font did not parse".to_string())?;
            Ok(())
        })
        .clone()
        .map_err(Error::invalid)
}

/// A regular text style of `size` pixels.
pub(crate) fn text(size: f64, color: RGBColor) -> TextStyle<'static> {
    let mut t = TextStyle::from((FAMILY, size, FontStyle::Normal));
    t.color = color.to_backend_color();
    t
}

/// A bold text style of `size` pixels.
pub(crate) fn bold(size: f64, color: RGBColor) -> TextStyle<'static> {
    let mut t = TextStyle::from((FAMILY, size, FontStyle::Bold));
    t.color = color.to_backend_color();
    t
}

// ------------------------------------------------------------ bitmap text

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use plotters::prelude::{BitMapBackend, DrawingBackend};
use plotters_backend::{
    text_anchor::{HPos, VPos},
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind,
};

fn face(bold: bool) -> Option<&'static FontRef<'static>> {
    static REGULAR: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    static BOLD: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    if bold {
        BOLD.get_or_init(|| FontRef::try_from_slice(dejavu::sans::bold()).ok())
            .as_ref()
    } else {
        REGULAR
            .get_or_init(|| FontRef::try_from_slice(dejavu::sans::regular()).ok())
            .as_ref()
    }
}

/// Width and height in pixels of `text` at `size` (the line height,
/// ascent − descent, as in plotters), with kerning.
pub fn text_size(text: &str, size: f64, bold: bool) -> (u32, u32) {
    let Some(font) = face(bold) else {
        return (0, 0);
    };
    let sf = font.as_scaled(PxScale::from(size as f32));
    let mut caret = 0.0f32;
    let mut prev = None;
    for ch in text.chars() {
        let id = sf.glyph_id(ch);
        if let Some(p) = prev {
            caret += sf.kern(p, id);
        }
        caret += sf.h_advance(id);
        prev = Some(id);
    }
    (caret.ceil() as u32, size.round() as u32)
}

/// Rasterises `text` with its layout box's top left at (0, 0) (the top is
/// the ascent line), calling `put(x, y, coverage)` for every covered pixel.
fn rasterise(text: &str, size: f64, bold: bool, mut put: impl FnMut(i32, i32, f32)) {
    let Some(font) = face(bold) else {
        return;
    };
    let scale = PxScale::from(size as f32);
    let sf = font.as_scaled(scale);
    let ascent = sf.ascent();
    let mut caret = 0.0f32;
    let mut prev = None;
    for ch in text.chars() {
        let id = sf.glyph_id(ch);
        if let Some(p) = prev {
            caret += sf.kern(p, id);
        }
        let glyph = id.with_scale_and_position(scale, point(caret, ascent));
        caret += sf.h_advance(id);
        prev = Some(id);
        if let Some(outline) = font.outline_glyph(glyph) {
            let b = outline.px_bounds();
            let (bx, by) = (b.min.x as i32, b.min.y as i32);
            outline.draw(|x, y, c| put(bx + x as i32, by + y as i32, c));
        }
    }
}

/// A bitmap backend whose text is laid out by ab_glyph with side bearings
/// and kerning (plotters' own ab_glyph path drops the left side bearing,
/// which makes letter spacing uneven). Everything else is delegated.
pub(crate) struct GlyphBackend<'a> {
    pub inner: BitMapBackend<'a>,
}

impl<'a> GlyphBackend<'a> {
    pub fn with_buffer(buf: &'a mut [u8], size: (u32, u32)) -> Self {
        GlyphBackend {
            inner: BitMapBackend::with_buffer(buf, size),
        }
    }
}

type BErr = <BitMapBackend<'static> as DrawingBackend>::ErrorType;

impl DrawingBackend for GlyphBackend<'_> {
    type ErrorType = BErr;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }
    fn ensure_prepared(&mut self) -> std::result::Result<(), DrawingErrorKind<BErr>> {
        self.inner.ensure_prepared()
    }
    fn present(&mut self) -> std::result::Result<(), DrawingErrorKind<BErr>> {
        self.inner.present()
    }
    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> std::result::Result<(), DrawingErrorKind<BErr>> {
        self.inner.draw_pixel(point, color)
    }
    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> std::result::Result<(), DrawingErrorKind<BErr>> {
        self.inner.draw_line(from, to, style)
    }
    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> std::result::Result<(), DrawingErrorKind<BErr>> {
        self.inner.draw_rect(upper_left, bottom_right, style, fill)
    }
    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> std::result::Result<(), DrawingErrorKind<BErr>> {
        self.inner.draw_path(path, style)
    }
    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> std::result::Result<(), DrawingErrorKind<BErr>> {
        self.inner.draw_circle(center, radius, style, fill)
    }
    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> std::result::Result<(), DrawingErrorKind<BErr>> {
        self.inner.fill_polygon(vert, style)
    }
    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> std::result::Result<(), DrawingErrorKind<BErr>> {
        self.inner.blit_bitmap(pos, size, src)
    }

    fn estimate_text_size<TStyle: BackendTextStyle>(
        &self,
        text: &str,
        style: &TStyle,
    ) -> std::result::Result<(u32, u32), DrawingErrorKind<BErr>> {
        let bold = matches!(style.style(), plotters_backend::FontStyle::Bold);
        Ok(text_size(text, style.size(), bold))
    }

    fn draw_text<TStyle: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &TStyle,
        pos: BackendCoord,
    ) -> std::result::Result<(), DrawingErrorKind<BErr>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let bold = matches!(style.style(), plotters_backend::FontStyle::Bold);
        let (width, height) = text_size(text, style.size(), bold);
        let (width, height) = (width as i32, height as i32);
        let anchor = style.anchor();
        let dx = match anchor.h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match anchor.v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let trans = style.transform();
        let (w, h) = self.get_size();
        let mut result = Ok(());
        rasterise(text, style.size(), bold, |x, y, c| {
            if result.is_err() || c <= 0.0 {
                return;
            }
            let (tx, ty) = trans.transform(x + dx, y + dy);
            let (px, py) = (pos.0 + tx, pos.1 + ty);
            if px >= 0 && py >= 0 && (px as u32) < w && (py as u32) < h {
                result = self.inner.draw_pixel(
                    (px, py),
                    BackendColor {
                        alpha: color.alpha * c.min(1.0) as f64,
                        rgb: color.rgb,
                    },
                );
            }
        });
        result
    }
}
