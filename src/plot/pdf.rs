//! PDF output: every PDF is converted from the figure's SVG by `usvg` +
//! `svg2pdf` (pure Rust), with the bundled DejaVu Sans as the only font
//! (the SVGs name the family `sans-serif`), so the text stays text
//! (embedded, subset, selectable) and no system font is consulted.
//!
//! One SVG pixel is one CSS pixel (1/96 in): a 1200 × 800 chart is a
//! 900 × 600 pt page (12.5 × 8.3 in), to be scaled in the document.

use std::sync::{Arc, OnceLock};

use crate::{Error, Result};

/// The family name of the bundled font in the font database.
const DEJAVU: &str = "DejaVu Sans";

/// A font database holding only the bundled DejaVu Sans (regular, bold),
/// which also serves every generic family.
fn fonts() -> Arc<usvg::fontdb::Database> {
    static DB: OnceLock<Arc<usvg::fontdb::Database>> = OnceLock::new();
    DB.get_or_init(|| {
        let mut db = usvg::fontdb::Database::new();
        db.load_font_data(dejavu::sans::regular().to_vec());
        db.load_font_data(dejavu::sans::bold().to_vec());
        db.set_sans_serif_family(DEJAVU);
        db.set_serif_family(DEJAVU);
        db.set_monospace_family(DEJAVU);
        db.set_cursive_family(DEJAVU);
        db.set_fantasy_family(DEJAVU);
        Arc::new(db)
    })
    .clone()
}

/// The PDF (one page, the SVG's size at 96 px per inch) of an SVG
/// document; `name` names the output in errors.
pub fn svg_to_pdf(svg: &str, name: &str) -> Result<Vec<u8>> {
    let opts = usvg::Options {
        font_family: DEJAVU.to_string(),
        fontdb: fonts(),
        ..Default::default()
    };
    let tree = usvg::Tree::from_str(svg, &opts)
        .map_err(|e| Error::invalid(format!("{name}: the SVG did not parse for PDF: {e}")))?;
    svg2pdf::to_pdf(
        &tree,
        svg2pdf::ConversionOptions::default(),
        svg2pdf::PageOptions { dpi: 96.0 },
    )
    .map_err(|e| Error::invalid(format!("{name}: PDF conversion failed: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_converts_with_the_bundled_font() {
        let svg = r#"<svg width="200" height="100" viewBox="0 0 200 100" xmlns="http://www.w3.org/2000/svg">
<rect x="0" y="0" width="200" height="100" fill="white"/>
<text x="10" y="50" font-family="sans-serif" font-size="20">B′ √area</text>
<text x="10" y="80" font-family="sans-serif" font-weight="bold" font-size="16">bold</text>
</svg>"#;
        let pdf = svg_to_pdf(svg, "t.pdf").unwrap();
        assert!(pdf.starts_with(b"%PDF-"));
        let text = String::from_utf8_lossy(&pdf);
        assert!(text.contains("/Type /Page"), "no page");
        assert!(text.contains("DejaVu"), "font not embedded");
        // 200 × 100 px at 96 px per inch: 150 × 75 pt.
        assert!(text.contains("/MediaBox [0 0 150 75]"), "{text:.400}");
    }
}
