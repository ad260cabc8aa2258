//! Valid ranges of numeric config keys and command-line numbers.
//!
//! A key's range is written once, on the key's definition in
//! [`super::config`] (`deserialize_with = "Int::<1, 1000>::de"`), and is
//! checked while the TOML is read, so an out-of-range value is an error
//! naming the file, the key, the line, the value and the range before
//! anything runs. A command-line flag with the same meaning uses the same
//! range through a type alias ([`crate::methods::spec::NCandidates`], …) and its
//! `parse` function as the clap value parser. `experiments/README.md` lists
//! every key with its range (a test compares them).
//!
//! Values that depend on the data (e.g. `n_candidates` above the vertex
//! count) are checked once the dataset is open, before any case runs
//! ([`super::feasible`]).

use std::fmt;
use std::marker::PhantomData;

use serde::de::{self, Visitor};
use serde::{Deserialize, Deserializer};

/// The integer range `MIN..=MAX`.
#[derive(Clone, Copy, Debug, Default)]
pub struct Int<const MIN: u64, const MAX: u64>;

impl<const MIN: u64, const MAX: u64> Int<MIN, MAX> {
    pub const MIN: u64 = MIN;
    pub const MAX: u64 = MAX;

    /// `MIN..=MAX`, as in the messages and the key reference.
    pub fn describe() -> String {
        format!("{MIN}..={MAX}")
    }

    /// The value if it is in range, else the message
    /// `"<value> is out of range; expected <range>"`.
    pub fn check(v: i128) -> Result<u64, String> {
        if (i128::from(MIN)..=i128::from(MAX)).contains(&v) {
            Ok(v as u64)
        } else {
            Err(format!(
                "{v} is out of range; expected an integer in {}",
                Self::describe()
            ))
        }
    }

    /// A command-line value parser (`#[arg(value_parser = X::parse)]`).
    pub fn parse(s: &str) -> Result<usize, String> {
        let v: i128 = s
            .trim()
            .parse()
            .map_err(|_| format!("{s:?} is not an integer; expected {}", Self::describe()))?;
        let v = Self::check(v)?;
        usize::try_from(v).map_err(|_| format!("{v} does not fit this machine's integers"))
    }

    /// A command-line value parser for a `u32` flag.
    pub fn parse_u32(s: &str) -> Result<u32, String> {
        let v = Self::parse(s)?;
        u32::try_from(v).map_err(|_| format!("{v} is out of range for a 32-bit integer"))
    }

    /// `deserialize_with` of an `Option<usize>` key.
    pub fn de<'de, D: Deserializer<'de>>(d: D) -> Result<Option<usize>, D::Error> {
        let v = d.deserialize_any(IntVisitor::<MIN, MAX>)?;
        usize::try_from(v)
            .map(Some)
            .map_err(|_| de::Error::custom(format!("{v} does not fit this machine's integers")))
    }

    /// `deserialize_with` of an `Option<u32>` key.
    pub fn de_u32<'de, D: Deserializer<'de>>(d: D) -> Result<Option<u32>, D::Error> {
        let v = d.deserialize_any(IntVisitor::<MIN, MAX>)?;
        u32::try_from(v)
            .map(Some)
            .map_err(|_| de::Error::custom(format!("{v} is out of range for a 32-bit integer")))
    }
}

struct IntVisitor<const MIN: u64, const MAX: u64>;

impl<'de, const MIN: u64, const MAX: u64> Visitor<'de> for IntVisitor<MIN, MAX> {
    type Value = u64;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "an integer in {}", Int::<MIN, MAX>::describe())
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<u64, E> {
        Int::<MIN, MAX>::check(i128::from(v)).map_err(E::custom)
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<u64, E> {
        Int::<MIN, MAX>::check(i128::from(v)).map_err(E::custom)
    }

    fn visit_i128<E: de::Error>(self, v: i128) -> Result<u64, E> {
        Int::<MIN, MAX>::check(v).map_err(E::custom)
    }

    fn visit_u128<E: de::Error>(self, v: u128) -> Result<u64, E> {
        Int::<MIN, MAX>::check(i128::try_from(v).unwrap_or(i128::MAX)).map_err(E::custom)
    }
}

/// The bounds of a real range: `[MIN, MAX]`, each end open or closed, and
/// always finite (an infinite `MAX` means "no upper bound, finite").
pub trait RealBounds {
    const MIN: f64;
    const MAX: f64;
    const MIN_OPEN: bool = false;
    const MAX_OPEN: bool = false;
}

/// A real range (see [`RealBounds`]); the bounds are the types below.
#[derive(Clone, Copy, Debug, Default)]
pub struct Real<B>(PhantomData<B>);

impl<B: RealBounds> Real<B> {
    /// `[0, 1]`, `(0, 1)`, `[0, ∞)`: as in the messages and the key
    /// reference (an infinite end is never reached: values are finite).
    pub fn describe() -> String {
        let lo = if B::MIN_OPEN { '(' } else { '[' };
        let hi = if B::MAX_OPEN || B::MAX.is_infinite() {
            ')'
        } else {
            ']'
        };
        let end = |x: f64| {
            if x == f64::INFINITY {
                "∞".to_string()
            } else {
                format!("{x}")
            }
        };
        format!("{lo}{}, {}{hi}", end(B::MIN), end(B::MAX))
    }

    /// Whether `v` is finite and within the bounds.
    pub fn contains(v: f64) -> bool {
        let lo = if B::MIN_OPEN { v > B::MIN } else { v >= B::MIN };
        let hi = if B::MAX_OPEN { v < B::MAX } else { v <= B::MAX };
        v.is_finite() && lo && hi
    }

    /// The value if it is in range, else the message.
    pub fn check(v: f64) -> Result<f64, String> {
        if Self::contains(v) {
            Ok(v)
        } else {
            Err(format!(
                "{v} is out of range; expected a finite number in {}",
                Self::describe()
            ))
        }
    }

    /// A command-line value parser.
    pub fn parse(s: &str) -> Result<f64, String> {
        let v: f64 = s
            .trim()
            .parse()
            .map_err(|_| format!("{s:?} is not a number; expected {}", Self::describe()))?;
        Self::check(v)
    }

    /// `deserialize_with` of an `Option<f64>` key.
    pub fn de<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
        let v = f64::deserialize(d)?;
        Self::check(v).map(Some).map_err(de::Error::custom)
    }

    /// `deserialize_with` of an `Option<[f64; 2]>` key (each entry in range).
    pub fn de_pair<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[f64; 2]>, D::Error> {
        // A list of any length is read, so that a third value is refused
        // rather than dropped.
        let v = Vec::<f64>::deserialize(d)?;
        let [a, b] = v[..] else {
            return Err(de::Error::custom(format!(
                "expected two numbers, got {} ({v:?})",
                v.len()
            )));
        };
        for x in [a, b] {
            Self::check(x).map_err(de::Error::custom)?;
        }
        Ok(Some([a, b]))
    }
}

macro_rules! bounds {
    ($(#[$m:meta])* $name:ident: $lo:expr, $hi:expr $(, min_open = $mo:expr)? $(, max_open = $xo:expr)?) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, Default)]
        pub struct $name;
        impl RealBounds for $name {
            const MIN: f64 = $lo;
            const MAX: f64 = $hi;
            $(const MIN_OPEN: bool = $mo;)?
            $(const MAX_OPEN: bool = $xo;)?
        }
    };
}

bounds!(
    /// `[0, ∞)`, finite.
    NonNegative: 0.0, f64::INFINITY
);
bounds!(
    /// `[0, 1e6]`: a weight of an energy term against another (ARAP's λ):
    /// beyond it the other term vanishes in rounding and the solve breaks
    /// per case (λ = 1e308 overflowed the system).
    Weight: 0.0, 1e6
);
bounds!(
    /// `(0, ∞)`, finite.
    Positive: 0.0, f64::INFINITY, min_open = true
);
bounds!(
    /// `[0, 1]`.
    UnitInterval: 0.0, 1.0
);
bounds!(
    /// `(0, 1)`.
    OpenUnitInterval: 0.0, 1.0, min_open = true, max_open = true
);
bounds!(
    /// `[0.001, 1000]`: a scale factor of a mesh (beyond it squared lengths
    /// of ordinary meshes leave the comfortable range of `f64`).
    ScaleFactor: 0.001, 1000.0
);
bounds!(
    /// `[-360, 360]` degrees.
    Degrees: -360.0, 360.0
);
bounds!(
    /// `[0, 0.4]`: the synthetic set's proportion spread
    /// ([`crate::data::synthetic::MAX_SPREAD`]).
    Spread: 0.0, crate::data::synthetic::MAX_SPREAD
);
bounds!(
    /// `[1e-15, 1e-3]`: an active-set tolerance in weight units (below
    /// 1e-15 the test is under the rounding of `Q x`; above 1e-3 the
    /// weights are visibly off).
    ActiveSetTol: 1e-15, 1e-3
);
bounds!(
    /// `[0, 1e-2]`: the step test of the coupled weights' support iteration
    /// in weight units (0 = off; above 1e-2 it would stop before the
    /// supports took shape).
    StepTol: 0.0, 1e-2
);
bounds!(
    /// `[0.3, 2]`: the vertex ratio of the synthetic remesh.
    RemeshRatio: 0.3, 2.0
);
bounds!(
    /// `[0.5, 16]` inches: a chart's width or height (at most 600 dpi,
    /// the PNG stays within 10 000 pixels a side).
    ChartInches: 0.5, 16.0
);
bounds!(
    /// `[4, 36]` points: the text of a chart.
    FontPoints: 4.0, 36.0
);
bounds!(
    /// `[50, 600]`: pixels per inch of a chart's PNG.
    Dpi: 50.0, 600.0
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn describes_and_checks() {
        assert_eq!(Int::<1, 10>::describe(), "1..=10");
        assert!(Int::<1, 10>::check(0).is_err());
        assert_eq!(Int::<1, 10>::check(10), Ok(10));
        let e = Int::<1, 10>::check(1_000_000_000).unwrap_err();
        assert!(e.contains("1000000000") && e.contains("1..=10"), "{e}");
        assert!(Int::<1, 10>::parse("-3").unwrap_err().contains("-3"));
        assert!(Int::<1, 10>::parse("x").is_err());
        assert_eq!(Real::<NonNegative>::describe(), "[0, ∞)");
        assert_eq!(Real::<OpenUnitInterval>::describe(), "(0, 1)");
        assert_eq!(Real::<Spread>::describe(), "[0, 0.4]");
        assert!(Real::<NonNegative>::check(f64::NAN).is_err());
        assert!(Real::<NonNegative>::check(f64::INFINITY).is_err());
        assert!(Real::<Positive>::check(0.0).is_err());
        assert!(Real::<OpenUnitInterval>::check(1.0).is_err());
        assert_eq!(Real::<Degrees>::check(-360.0), Ok(-360.0));
        assert!(Real::<Degrees>::parse("nan").is_err());
    }
}
