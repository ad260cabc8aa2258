//! Axis coordinates for plotters: linear and logarithmic value axes with
//! "nice" ticks (1, 2, 5 × 10^k; decades on log axes), and a category axis
//! whose ticks sit at the category centres 0, 1, …, n − 1.

use std::ops::Range;

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};

/// How values map to pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scale {
    Linear,
    /// Base-10 logarithmic; the range must be positive.
    Log,
    /// `n` categories centred at 0, …, n − 1 on the range [−0.5, n − 0.5].
    Category(usize),
    /// Linear, for integer-valued data (counts): ticks only at integers.
    Integer,
}

/// One axis: a value range and a scale. Implements plotters' [`Ranged`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axis {
    pub lo: f64,
    pub hi: f64,
    pub scale: Scale,
}

impl Axis {
    pub fn linear(lo: f64, hi: f64) -> Self {
        Axis {
            lo,
            hi,
            scale: Scale::Linear,
        }
    }

    pub fn log(lo: f64, hi: f64) -> Self {
        Axis {
            lo,
            hi,
            scale: Scale::Log,
        }
    }

    /// A linear axis whose ticks are integers (for counts such as the
    /// number of key points or examples).
    pub fn integer(lo: f64, hi: f64) -> Self {
        Axis {
            lo,
            hi,
            scale: Scale::Integer,
        }
    }

    pub fn category(n: usize) -> Self {
        Axis {
            lo: -0.5,
            hi: n as f64 - 0.5,
            scale: Scale::Category(n),
        }
    }

    /// The value in axis space (log10 on log axes); linear in pixels.
    pub fn forward(&self, v: f64) -> f64 {
        match self.scale {
            Scale::Log => v.log10(),
            _ => v,
        }
    }

    /// Inverse of [`Axis::forward`].
    pub fn backward(&self, u: f64) -> f64 {
        match self.scale {
            Scale::Log => 10f64.powf(u),
            _ => u,
        }
    }

    /// Fraction of the way from `lo` to `hi` in axis space.
    pub fn fraction(&self, v: f64) -> f64 {
        let (a, b) = (self.forward(self.lo), self.forward(self.hi));
        (self.forward(v) - a) / (b - a)
    }

    /// The major tick values (at most about `max` of them) and the tick
    /// step used for formatting (for log axes, the decade step).
    pub fn major_ticks(&self, max: usize) -> (Vec<f64>, f64) {
        match self.scale {
            Scale::Category(n) => ((0..n).map(|i| i as f64).collect(), 1.0),
            Scale::Linear => {
                let step = nice_step(self.hi - self.lo, max.max(2));
                (ticks_in(self.lo, self.hi, step), step)
            }
            Scale::Integer => {
                let step = nice_step(self.hi - self.lo, max.max(2)).max(1.0).ceil();
                (ticks_in(self.lo, self.hi, step), step)
            }
            Scale::Log => {
                let (a, b) = (self.lo.log10(), self.hi.log10());
                let decades: Vec<f64> = ((a - 1e-9).ceil() as i32..=(b + 1e-9).floor() as i32)
                    .map(|k| 10f64.powi(k))
                    .collect();
                if (2..=3).contains(&decades.len()) {
                    // Two or three decades: label 1, 2, 5 multiples too.
                    let mut v = Vec::new();
                    for k in (a.floor() as i32)..=(b.ceil() as i32) {
                        for m in [1.0, 2.0, 5.0] {
                            let t = m * 10f64.powi(k);
                            if t >= self.lo * (1.0 - 1e-9) && t <= self.hi * (1.0 + 1e-9) {
                                v.push(t);
                            }
                        }
                    }
                    (v, 10.0)
                } else if decades.len() >= 2 {
                    // Thin out decades if there are too many.
                    let every = decades.len().div_ceil(max.max(2));
                    let kept = decades.iter().copied().step_by(every.max(1)).collect();
                    (kept, 10f64.powi(every as i32))
                } else {
                    // Less than a decade in view: 1, 2, 5 multiples.
                    let mut v = Vec::new();
                    for k in (a.floor() as i32 - 1)..=(b.ceil() as i32) {
                        for m in [1.0, 2.0, 5.0] {
                            let t = m * 10f64.powi(k);
                            if t >= self.lo * (1.0 - 1e-9) && t <= self.hi * (1.0 + 1e-9) {
                                v.push(t);
                            }
                        }
                    }
                    if v.len() < 2 {
                        let step = nice_step(self.hi - self.lo, max.max(2));
                        return (ticks_in(self.lo, self.hi, step), step);
                    }
                    (v, 10.0)
                }
            }
        }
    }

    /// Minor tick values for light grid lines.
    pub fn minor_ticks(&self, max_major: usize) -> Vec<f64> {
        match self.scale {
            Scale::Category(_) => Vec::new(),
            Scale::Linear => {
                let (_, step) = self.major_ticks(max_major);
                let m = mantissa(step);
                let sub = if (m - 2.0).abs() < 1e-6 { 4.0 } else { 5.0 };
                ticks_in(self.lo, self.hi, step / sub)
            }
            Scale::Integer => {
                let (_, step) = self.major_ticks(max_major);
                if step > 1.0 && self.hi - self.lo <= 50.0 {
                    ticks_in(self.lo, self.hi, 1.0)
                } else {
                    Vec::new()
                }
            }
            Scale::Log => {
                let (a, b) = (self.lo.log10(), self.hi.log10());
                if b - a > 6.0 {
                    return Vec::new();
                }
                let mut v = Vec::new();
                for k in (a.floor() as i32)..=(b.ceil() as i32) {
                    for m in 1..10 {
                        let t = m as f64 * 10f64.powi(k);
                        if t >= self.lo && t <= self.hi {
                            v.push(t);
                        }
                    }
                }
                v
            }
        }
    }
}

/// `m` of `m × 10^k`.
fn mantissa(step: f64) -> f64 {
    step / 10f64.powf(step.log10().floor())
}

/// The smallest step from {1, 2, 2.5, 5} × 10^k giving at most `max`
/// intervals over `span`.
pub fn nice_step(span: f64, max: usize) -> f64 {
    let span = if span > 0.0 && span.is_finite() {
        span
    } else {
        1.0
    };
    let raw = span / max as f64;
    let p = 10f64.powf(raw.log10().floor());
    for m in [1.0, 2.0, 2.5, 5.0, 10.0] {
        if m * p >= raw * (1.0 - 1e-9) {
            return m * p;
        }
    }
    10.0 * p
}

/// Multiples of `step` in [lo, hi] (with a little tolerance).
fn ticks_in(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let eps = step * 1e-6;
    let first = ((lo - eps) / step).ceil() as i64;
    let last = ((hi + eps) / step).floor() as i64;
    if last < first || last - first > 10_000 {
        return Vec::new();
    }
    (first..=last)
        .map(|i| {
            let v = i as f64 * step;
            if v.abs() < eps {
                0.0
            } else {
                v
            }
        })
        .collect()
}

/// Tick label of `v` on a linear axis with tick spacing `step`: as many
/// decimals as the step needs; scientific (`2×10⁻⁵`) for very large or small
/// values.
pub fn format_tick(v: f64, step: f64) -> String {
    let mag = v.abs().max(step.abs());
    if !(1e-3..1e5).contains(&mag) {
        return if v == 0.0 { "0".into() } else { format_sci(v) };
    }
    let mut decimals = (-(step.log10() + 1e-9).floor()).max(0.0) as usize;
    let m = mantissa(step);
    if (m - 2.5).abs() < 1e-6 {
        decimals += 1;
    }
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s.replace('-', "−")
    }
}

/// Whether a log axis over `[lo, hi]` labels its ticks as powers of ten
/// (it reaches beyond 10⁻³ … 10⁴) rather than as plain decimals.
pub fn log_axis_is_scientific(lo: f64, hi: f64) -> bool {
    lo < 1e-3 * (1.0 - 1e-9) || hi > 1e4 * (1.0 + 1e-9)
}

/// Tick label on a log axis: plain decimals, or with `scientific`
/// `m×10ᵏ` with superscripts (`10ᵏ` for m = 1).
pub fn format_log_tick(v: f64, scientific: bool) -> String {
    if !scientific {
        let k = v.log10().floor();
        let decimals = (-k).max(0.0) as usize;
        format!("{v:.decimals$}")
    } else {
        format_sci(v)
    }
}

fn format_sci(v: f64) -> String {
    let k = (v.abs().log10() + 1e-9).floor() as i32;
    let m = v / 10f64.powi(k);
    let exp = superscript(k);
    if (m - 1.0).abs() < 1e-9 {
        format!("10{exp}")
    } else if (m + 1.0).abs() < 1e-9 {
        format!("−10{exp}")
    } else {
        let ms = format!("{m:.2}");
        let ms = ms
            .trim_end_matches('0')
            .trim_end_matches('.')
            .replace('-', "−");
        format!("{ms}×10{exp}")
    }
}

fn superscript(k: i32) -> String {
    const DIGITS: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let mut s = String::new();
    if k < 0 {
        s.push('⁻');
    }
    for c in k.unsigned_abs().to_string().chars() {
        s.push(DIGITS[c.to_digit(10).unwrap_or(0) as usize]);
    }
    s
}

impl Ranged for Axis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let f = self.fraction(*value);
        let p = limit.0 as f64 + f * (limit.1 - limit.0) as f64;
        p.round().clamp(-1e6, 1e6) as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        let max = hint.bold_points().max(2);
        if hint.weight().allow_light_points() {
            self.minor_ticks(max)
        } else {
            self.major_ticks(max).0
        }
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_steps() {
        assert_eq!(nice_step(1.0, 5), 0.2);
        assert_eq!(nice_step(10.0, 4), 2.5);
        assert_eq!(nice_step(0.07, 7), 0.01);
        assert_eq!(ticks_in(0.0, 1.0, 0.25), vec![0.0, 0.25, 0.5, 0.75, 1.0]);
    }

    #[test]
    fn integer_axis_ticks_only_integers() {
        let (t, step) = Axis::integer(0.9, 4.1).major_ticks(10);
        assert_eq!(t, vec![1.0, 2.0, 3.0, 4.0]);
        assert_eq!(step, 1.0);
        assert!(Axis::integer(0.9, 4.1).minor_ticks(10).is_empty());
        let (t, _) = Axis::integer(0.0, 30.0).major_ticks(4);
        assert!(t.iter().all(|v| v.fract() == 0.0), "{t:?}");
        assert!(Axis::integer(0.0, 30.0)
            .minor_ticks(4)
            .iter()
            .all(|v| v.fract() == 0.0));
    }

    #[test]
    fn formats() {
        assert_eq!(format_tick(0.5, 0.1), "0.5");
        assert_eq!(format_tick(0.25, 0.25), "0.25");
        assert_eq!(format_tick(2.5, 2.5), "2.5");
        assert_eq!(format_tick(40.0, 20.0), "40");
        assert_eq!(format_tick(2e-5, 1e-5), "2×10⁻⁵");
        assert_eq!(format_tick(-0.5, 0.5), "−0.5");
        assert_eq!(format_tick(0.0, 0.2), "0.0");
        assert_eq!(format_log_tick(0.001, false), "0.001");
        assert_eq!(format_log_tick(100.0, false), "100");
        assert_eq!(format_log_tick(1e-5, true), "10⁻⁵");
        assert_eq!(format_log_tick(0.01, true), "10⁻²");
        assert_eq!(format_log_tick(200.0, true), "2×10²");
        assert!(log_axis_is_scientific(1e-4, 1.0));
        assert!(!log_axis_is_scientific(1e-3, 1e4));
    }

    #[test]
    fn log_ticks_are_decades() {
        let b = Axis::log(1e-3, 1e-1);
        assert_eq!(b.major_ticks(8).0.len(), 7);
        let a = Axis::log(1e-4, 1.0);
        assert_eq!(a.major_ticks(8).0, vec![1e-4, 1e-3, 1e-2, 1e-1, 1.0]);
        assert!((a.fraction(1e-2) - 0.5).abs() < 1e-12);
    }
}
