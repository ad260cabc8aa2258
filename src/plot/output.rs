//! In-memory RGB images and atomic file output (temporary file in the target
//! directory, then rename), so a reader never sees a half-written figure.

use std::ffi::OsString;
use std::path::{Path, PathBuf};

use plotters::prelude::*;

use crate::mesh::io::temp::{self, commit};
use crate::{Error, Result};

/// An 8-bit sRGB image, rows top to bottom, 3 bytes per pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
}

impl Image {
    /// A `width` × `height` image filled with `color`.
    pub fn new(width: u32, height: u32, color: [u8; 3]) -> Self {
        let n = width as usize * height as usize;
        let mut rgb = Vec::with_capacity(3 * n);
        for _ in 0..n {
            rgb.extend_from_slice(&color);
        }
        Image { width, height, rgb }
    }

    /// The pixel at column `x`, row `y` (`None` outside).
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = 3 * (y as usize * self.width as usize + x as usize);
        Some([self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]])
    }

    /// Sets a pixel; ignores positions outside the image.
    pub fn set(&mut self, x: u32, y: u32, c: [u8; 3]) {
        if x < self.width && y < self.height {
            let i = 3 * (y as usize * self.width as usize + x as usize);
            self.rgb[i..i + 3].copy_from_slice(&c);
        }
    }

    /// Copies `src` with its top left corner at `(x0, y0)` (clipped).
    pub fn blit(&mut self, src: &Image, x0: u32, y0: u32) {
        for y in 0..src.height {
            let ty = y0 + y;
            if ty >= self.height {
                break;
            }
            let w = src.width.min(self.width.saturating_sub(x0)) as usize;
            if w == 0 {
                return;
            }
            let s = 3 * (y as usize * src.width as usize);
            let d = 3 * (ty as usize * self.width as usize + x0 as usize);
            self.rgb[d..d + 3 * w].copy_from_slice(&src.rgb[s..s + 3 * w]);
        }
    }

    /// Box-filter downsampling by an integer `factor` (1 returns a copy).
    pub fn downsample(&self, factor: u32) -> Image {
        let f = factor.max(1);
        if f == 1 {
            return self.clone();
        }
        let (w, h) = (self.width / f, self.height / f);
        let mut out = Image::new(w, h, [0, 0, 0]);
        let n = f * f;
        for y in 0..h {
            for x in 0..w {
                let mut acc = [0u32; 3];
                for dy in 0..f {
                    let row = 3 * ((y * f + dy) as usize * self.width as usize);
                    for dx in 0..f {
                        let i = row + 3 * (x * f + dx) as usize;
                        for (a, &c) in acc.iter_mut().zip(&self.rgb[i..i + 3]) {
                            *a += c as u32;
                        }
                    }
                }
                let c = [
                    ((acc[0] + n / 2) / n) as u8,
                    ((acc[1] + n / 2) / n) as u8,
                    ((acc[2] + n / 2) / n) as u8,
                ];
                out.set(x, y, c);
            }
        }
        out
    }
}

/// Which files a figure is written as: `stem.png` (raster), `stem.svg`
/// (vector; renders: the mesh raster under vector text) and `stem.pdf`
/// (converted from the SVG, [`super::pdf`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Formats {
    pub png: bool,
    pub svg: bool,
    pub pdf: bool,
}

impl Formats {
    /// What the chart functions (`save_line_chart`, …) write by default:
    /// PNG, SVG and PDF.
    pub const CHARTS: Formats = Formats {
        png: true,
        svg: true,
        pdf: true,
    };
    /// What the render functions (`save_figure`, …) write by default: PNG.
    pub const RENDERS: Formats = Formats {
        png: true,
        svg: false,
        pdf: false,
    };
    /// The format names accepted by [`Formats::from_names`].
    pub const NAMES: [&'static str; 3] = ["png", "svg", "pdf"];

    /// The formats named (`"png"`, `"svg"`, `"pdf"`); errors on another
    /// name and on an empty list.
    pub fn from_names<S: AsRef<str>>(names: &[S]) -> std::result::Result<Formats, String> {
        let mut f = Formats {
            png: false,
            svg: false,
            pdf: false,
        };
        for n in names {
            match n.as_ref() {
                "png" => f.png = true,
                "svg" => f.svg = true,
                "pdf" => f.pdf = true,
                other => {
                    return Err(format!(
                        "unknown format {other:?}; expected some of \"png\", \"svg\", \"pdf\""
                    ))
                }
            }
        }
        if f.is_empty() {
            return Err("expected at least one format (\"png\", \"svg\", \"pdf\")".into());
        }
        Ok(f)
    }

    /// Whether no format is chosen.
    pub fn is_empty(&self) -> bool {
        !(self.png || self.svg || self.pdf)
    }

    /// The extensions chosen, in the order png, svg, pdf.
    pub fn extensions(&self) -> Vec<&'static str> {
        [(self.png, "png"), (self.svg, "svg"), (self.pdf, "pdf")]
            .iter()
            .filter(|(on, _)| *on)
            .map(|(_, e)| *e)
            .collect()
    }

    /// `stem.{png,svg,pdf}` (the chosen ones), for messages.
    pub fn describe(&self, stem: &Path) -> String {
        format!("{}.{{{}}}", stem.display(), self.extensions().join(","))
    }
}

/// `stem` with `.ext` appended (not replacing an existing extension:
/// `fig.v2` gives `fig.v2.png`). Errors if `stem` has no file name.
pub fn with_suffix(stem: &Path, ext: &str) -> Result<PathBuf> {
    if stem.file_name().is_none() {
        return Err(Error::invalid(format!(
            "{}: output path has no file name",
            stem.display()
        )));
    }
    let mut s: OsString = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    Ok(PathBuf::from(s))
}

/// A fresh temporary path of this process next to `path`, ending in
/// `.tmp.<ext>` (the PNG encoder picks the format from the extension;
/// [`crate::mesh::io::temp`]). Creates the directory.
fn temp_path(path: &Path, ext: &str) -> Result<PathBuf> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let name = path.file_name().unwrap_or_default();
    Ok(temp::temp_path(&dir.join(name), Some(ext)))
}

/// Writes `bytes` to `path` atomically, creating parent directories.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    if let Some(d) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d).map_err(|e| Error::io(d, e))?;
    }
    let tmp = temp::write_temp(path, bytes, false)?;
    commit(&tmp, path)
}

/// The PNG encoding of `image` (8-bit RGB), in memory.
pub fn encode_png(image: &Image) -> Result<Vec<u8>> {
    encode_png_dpi(image, None)
}

/// [`encode_png`] with the resolution recorded (a `pHYs` chunk, pixels
/// per metre) when `dpi` is given, so that a document or viewer places the
/// image at its physical size.
pub fn encode_png_dpi(image: &Image, dpi: Option<f64>) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    let fail = |e: png::EncodingError| Error::invalid(format!("PNG encoding failed: {e}"));
    if image.width == 0 || image.height == 0 {
        return Err(Error::invalid(format!(
            "image of size {}×{} cannot be written",
            image.width, image.height
        )));
    }
    {
        let mut enc = png::Encoder::new(&mut out, image.width, image.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        if let Some(dpi) = dpi.filter(|d| d.is_finite() && *d > 0.0) {
            let ppm = (dpi / 0.0254).round() as u32;
            enc.set_pixel_dims(Some(png::PixelDimensions {
                xppu: ppm,
                yppu: ppm,
                unit: png::Unit::Meter,
            }));
        }
        let mut w = enc.write_header().map_err(fail)?;
        w.write_image_data(&image.rgb).map_err(fail)?;
        w.finish().map_err(fail)?;
    }
    Ok(out)
}

/// Standard base64 (RFC 4648, with padding) of `bytes`.
pub fn base64(bytes: &[u8]) -> String {
    use base64::Engine;
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

/// Encodes `image` as PNG at `path` atomically, creating parent directories.
pub fn write_png_atomic(path: &Path, image: &Image) -> Result<()> {
    if image.width == 0 || image.height == 0 {
        return Err(Error::invalid(format!(
            "{}: image of size {}×{} cannot be written",
            path.display(),
            image.width,
            image.height
        )));
    }
    let tmp = temp_path(path, "png")?;
    let result = (|| {
        let backend = BitMapBackend::new(&tmp, (image.width, image.height));
        let root = backend.into_drawing_area();
        root.draw(
            &plotters::element::BitMapElement::with_ref(
                (0, 0),
                (image.width, image.height),
                &image.rgb,
            )
            .ok_or_else(|| "buffer size does not match the image".to_string())?,
        )
        .map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())
    })();
    match result {
        Ok(()) => commit(&tmp, path),
        Err(msg) => {
            let _ = std::fs::remove_file(&tmp);
            Err(Error::invalid(format!(
                "{}: PNG encoding failed: {msg}",
                path.display()
            )))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_the_rfc_examples() {
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(plain.as_bytes()), coded);
        }
    }

    #[test]
    fn in_memory_png_has_the_size() {
        let png = encode_png(&Image::new(7, 3, [1, 2, 3])).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(&png[16..24], &[0, 0, 0, 7, 0, 0, 0, 3]);
    }
}
