//! Colours and line styles: the perceptual colour map for scalar fields, the
//! key point palette, and the per-series styles of line and bar charts.

/// Control points of the viridis colour map at t = 0, 1/8, …, 1 (sRGB),
/// linearly interpolated in between. Viridis (van der Walt and Smith, 2015)
/// is perceptually uniform, monotone in lightness (readable in grey scale)
/// and colour-blind safe.
const VIRIDIS: [[u8; 3]; 9] = [
    [68, 1, 84],    // #440154
    [71, 45, 123],  // #472D7B
    [59, 82, 139],  // #3B528B
    [44, 114, 142], // #2C728E
    [33, 144, 140], // #21908C
    [39, 173, 129], // #27AD81
    [93, 200, 99],  // #5DC863
    [170, 220, 50], // #AADC32
    [253, 231, 37], // #FDE725
];

/// Viridis-like colour map: `t` in [0, 1] (clamped; NaN maps to 0) from dark
/// purple through teal and green to yellow.
pub fn colormap(t: f64) -> [u8; 3] {
    ColorMap::Viridis.color(t)
}

/// ColorBrewer "Reds" (9 classes) as control points at t = 0, 1/8, …, 1:
/// near white through red to dark red; single hue, monotone lightness.
const REDS: [[u8; 3]; 9] = [
    [255, 245, 240], // #FFF5F0
    [254, 224, 210], // #FEE0D2
    [252, 187, 161], // #FCBBA1
    [252, 146, 114], // #FC9272
    [251, 106, 74],  // #FB6A4A
    [239, 59, 44],   // #EF3B2C
    [203, 24, 29],   // #CB181D
    [165, 15, 21],   // #A50F15
    [103, 0, 13],    // #67000D
];

/// A sequential colour map for scalar fields.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ColorMap {
    /// Dark purple → teal → yellow ([`colormap`]).
    #[default]
    Viridis,
    /// Near white → red → dark red: zero stays light, so shading keeps the
    /// shape readable where most of a heat map is near zero.
    Reds,
}

impl ColorMap {
    /// The colour at `t` in [0, 1] (clamped; NaN maps to 0).
    pub fn color(self, t: f64) -> [u8; 3] {
        match self {
            ColorMap::Viridis => interpolate(&VIRIDIS, t),
            ColorMap::Reds => interpolate(&REDS, t),
        }
    }
}

fn interpolate(table: &[[u8; 3]; 9], t: f64) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let n = table.len() - 1;
    let s = t * n as f64;
    let i = (s.floor() as usize).min(n - 1);
    let f = s - i as f64;
    let (a, b) = (table[i], table[i + 1]);
    let mix = |k: usize| (a[k] as f64 + f * (b[k] as f64 - a[k] as f64)).round() as u8;
    [mix(0), mix(1), mix(2)]
}

/// Hand-picked saturated colours for the first key points, chosen to be
/// distinct from each other, from white, from mid grey and from the colour
/// map's yellow end.
const KEYPOINT_PALETTE: [[u8; 3]; 12] = [
    [228, 26, 28],   // red
    [55, 126, 184],  // blue
    [77, 175, 74],   // green
    [152, 78, 163],  // purple
    [255, 127, 0],   // orange
    [0, 206, 209],   // turquoise
    [247, 129, 191], // pink
    [166, 86, 40],   // brown
    [30, 30, 30],    // near black
    [0, 0, 160],     // navy
    [180, 220, 0],   // lime
    [140, 0, 40],    // wine
];

/// Colour of key point `index`: the same index gets the same colour in every
/// panel and figure. Indices 0–11 use a fixed palette; later ones walk the
/// hue circle by the golden angle (fully saturated, alternating brightness),
/// so neighbouring indices stay distinguishable for any count.
pub fn keypoint_color(index: usize) -> [u8; 3] {
    if let Some(c) = KEYPOINT_PALETTE.get(index) {
        return *c;
    }
    let k = index - KEYPOINT_PALETTE.len();
    let hue = (k as f64 * 137.507_764) % 360.0;
    let value = if k % 2 == 0 { 0.95 } else { 0.7 };
    hsv_to_rgb(hue, 0.9, value)
}

/// HSV (hue in degrees, saturation and value in [0, 1]) to sRGB bytes.
fn hsv_to_rgb(h: f64, s: f64, v: f64) -> [u8; 3] {
    let c = v * s;
    let hp = (h.rem_euclid(360.0)) / 60.0;
    let x = c * (1.0 - (hp % 2.0 - 1.0).abs());
    let (r, g, b) = match hp as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    let q = |u: f64| ((u + m) * 255.0).round().clamp(0.0, 255.0) as u8;
    [q(r), q(g), q(b)]
}

/// Series colours of charts: the Okabe–Ito colour-blind-safe set without its
/// yellow (too light on white), plus black, brown and four darker colours
/// of Paul Tol's muted set: twelve colours, so a chart of up to twelve
/// series (bars carry no dash pattern) repeats none.
const SERIES_PALETTE: [[u8; 3]; 12] = [
    [0, 114, 178],   // blue
    [213, 94, 0],    // vermillion
    [0, 158, 115],   // bluish green
    [204, 121, 167], // reddish purple
    [230, 159, 0],   // orange
    [86, 180, 233],  // sky blue
    [0, 0, 0],       // black
    [120, 70, 30],   // brown
    [153, 153, 51],  // olive
    [136, 34, 85],   // wine
    [51, 34, 136],   // indigo
    [17, 119, 51],   // dark green
];

/// Dash pattern of a line: `None` solid, `Some((dash, gap))` in pixels at
/// the 1200-pixel-wide reference size.
pub type Dash = Option<(f64, f64)>;

/// Dash patterns used once there are more series than [`MAX_PLAIN_SERIES`].
const DASHES: [Dash; 3] = [None, Some((14.0, 7.0)), Some((4.0, 5.0))];

/// Up to this many series are told apart by colour alone (solid lines).
pub const MAX_PLAIN_SERIES: usize = 6;

/// Marker shapes of line charts (and of legends).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    Circle,
    Square,
    TriangleUp,
    Diamond,
    TriangleDown,
    Cross,
}

const MARKERS: [Marker; 6] = [
    Marker::Circle,
    Marker::Square,
    Marker::TriangleUp,
    Marker::Diamond,
    Marker::TriangleDown,
    Marker::Cross,
];

/// How series `index` of `count` is drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeriesStyle {
    pub color: [u8; 3],
    pub dash: Dash,
    pub marker: Marker,
}

/// The style of a reference floor series of a line chart
/// ([`super::LineChart::floor`]): dashed mid grey.
pub const FLOOR_STYLE: SeriesStyle = SeriesStyle {
    color: [128, 128, 128],
    dash: Some((10.0, 6.0)),
    marker: Marker::Cross,
};

/// The style of series `index` among `count` series: distinct colours; with
/// more than [`MAX_PLAIN_SERIES`] series also distinct dash patterns, so
/// that (colour, dash) pairs are unique up to 36 series; marker shapes cycle
/// through six shapes (drawn when the chart asks for markers, and always
/// when there are more than [`MAX_PLAIN_SERIES`] series).
pub fn series_style(index: usize, count: usize) -> SeriesStyle {
    let color = SERIES_PALETTE[index % SERIES_PALETTE.len()];
    // The dash shifts by one every full turn of the palette, so (colour,
    // dash) pairs stay unique over three turns.
    let turn = index / SERIES_PALETTE.len();
    let dash = if count > MAX_PLAIN_SERIES {
        DASHES[(index + turn) % DASHES.len()]
    } else {
        None
    };
    SeriesStyle {
        color,
        dash,
        marker: MARKERS[index % MARKERS.len()],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colormap_hits_control_points() {
        for (i, c) in VIRIDIS.iter().enumerate() {
            assert_eq!(colormap(i as f64 / 8.0), *c);
        }
    }

    /// Bars are told apart by colour alone: the first twelve series have
    /// twelve colours (a ten-method figure repeated two before).
    #[test]
    fn twelve_series_have_twelve_colours() {
        let colours: std::collections::BTreeSet<[u8; 3]> =
            (0..12).map(|i| series_style(i, 12).color).collect();
        assert_eq!(colours.len(), 12);
    }

    #[test]
    fn series_styles_are_unique_up_to_36() {
        let n = 36;
        let styles: Vec<_> = (0..n).map(|i| series_style(i, n)).collect();
        for i in 0..n {
            for j in 0..i {
                assert!(
                    (styles[i].color, styles[i].dash) != (styles[j].color, styles[j].dash),
                    "{i} and {j}"
                );
            }
        }
    }

    #[test]
    fn keypoint_colours_differ_from_neighbours() {
        for i in 0..60 {
            let (a, b) = (keypoint_color(i), keypoint_color(i + 1));
            let d: i32 = (0..3).map(|k| (a[k] as i32 - b[k] as i32).abs()).sum();
            assert!(d > 60, "{i}: {a:?} vs {b:?}");
        }
    }
}
