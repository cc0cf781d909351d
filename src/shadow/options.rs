//! Typed technique options and their one declaration per field.
//!
//! A technique's library API is a plain `Options` struct (`Default`, every field documented
//! with "Default: ..."). The CLI's `--set key=value`, `penumbra list` and the option check of
//! the library constructor all read one [`Declaration`]: a list of [`Field`]s, each naming
//! the struct field it maps to (by an accessor function), its key, documentation and, for
//! numbers, its range. No technique parses text by hand.
//!
//! Why a small trait ([`OptionValue`]) and a builder rather than a macro: the declaration
//! stays ordinary Rust (readable, formatted, checked by the compiler field by field), a field
//! type is added by one `impl`, and choice enums get their names from [`crate::choice_enum!`].
//! A group of options that several techniques hold (the map pass, the bias) declares its
//! fields once, on its own type; a technique takes them into its declaration with
//! [`within`], which reaches the group inside its `Options`.

use crate::error::Reason;
use crate::Error;
use std::fmt::Display;

/// A type an option can have: parsed from and shown as text (its `Display` is the text
/// that parses back to the same value).
pub trait OptionValue: Clone + Display + 'static {
    /// What `penumbra list` calls the type ("integer", "number", "bool", "text", or the
    /// choices joined by `|`).
    fn type_name() -> String;
    /// Parses a value; the error is the end of a sentence ("is not a number").
    fn parse(s: &str) -> Result<Self, Reason>;
    /// The value as text (parses back to the same value).
    fn show(&self) -> String {
        self.to_string()
    }
    /// For a choice, each value's name and what it means (empty for other types).
    fn choices() -> &'static [(&'static str, &'static str)] {
        &[]
    }
}

macro_rules! integer_option {
    ($t:ty) => {
        impl OptionValue for $t {
            fn type_name() -> String {
                "integer".into()
            }
            fn parse(s: &str) -> Result<Self, Reason> {
                s.parse().map_err(|_| integer_error(s, <$t>::MAX as f64).into())
            }
        }
    };
}
integer_option!(u32);
integer_option!(usize);

/// Why `s` is not an integer in `0..=max`, as the end of a sentence.
fn integer_error(s: &str, max: f64) -> String {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_nan() => "is not a number".into(),
        Ok(v) if v < 0.0 => "is negative (a whole number from 0 is expected)".into(),
        Ok(v) if v > max => format!("is too large (at most {max})"),
        Ok(v) if v.fract() != 0.0 => "is not a whole number".into(),
        Ok(v) => format!("is not written as an integer (write {v} in digits)"),
        Err(_) => "is not a number (an integer is expected)".into(),
    }
}

impl OptionValue for f32 {
    fn type_name() -> String {
        "number".into()
    }
    /// A finite number: NaN and infinities are refused here, before any range check.
    fn parse(s: &str) -> Result<Self, Reason> {
        match s.trim().parse::<f32>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => match s.trim().parse::<f64>() {
                Ok(w) if w.is_finite() => Err("is too large for a 32-bit float".into()),
                _ => Err("is not finite (NaN and infinities are not accepted)".into()),
            },
            Err(_) => Err("is not a number".into()),
        }
    }
}

impl OptionValue for bool {
    fn type_name() -> String {
        "bool".into()
    }
    /// `true`/`false`, also `on`/`off`.
    fn parse(s: &str) -> Result<Self, Reason> {
        match s {
            "true" | "on" => Ok(true),
            "false" | "off" => Ok(false),
            _ => Err("is not one of true, false (or on, off)".into()),
        }
    }
}

impl OptionValue for String {
    fn type_name() -> String {
        "text".into()
    }
    fn parse(s: &str) -> Result<Self, Reason> {
        Ok(s.to_string())
    }
}

/// Declares a `Copy` enum whose variants have option names, and its [`OptionValue`] impl.
/// Every variant has a doc comment: it is also what `penumbra list` and the explorer say of
/// the choice.
///
/// ```
/// penumbra::choice_enum! {
///     /// How to filter.
///     pub enum Filter {
///         /// One comparison.
///         None = "none",
///         /// 2x2 PCF
///         /// (hardware).
///         Pcf2 = "pcf2",
///     }
/// }
/// use penumbra::shadow::options::OptionValue;
/// assert_eq!(Filter::parse("pcf2").unwrap(), Filter::Pcf2);
/// assert!(Filter::parse("gauss").unwrap_err().0.contains("not one of none, pcf2"));
/// assert_eq!(Filter::choices()[1], ("pcf2", " 2x2 PCF (hardware)."));
/// ```
#[macro_export]
macro_rules! choice_enum {
    ($(#[$m:meta])* pub enum $name:ident { $($(#[doc = $doc:literal])+ $v:ident = $s:literal),+ $(,)? }) => {
        $(#[$m])*
        #[derive(Copy, Clone, Debug, PartialEq, Eq)]
        pub enum $name { $($(#[doc = $doc])+ $v),+ }
        impl $name {
            /// The option names of the variants, in declaration order.
            pub const NAMES: &'static [&'static str] = &[$($s),+];
            /// Each variant's option name and what it means, in declaration order.
            /// (A doc comment's lines joined: each line after the first starts with its
            /// space.)
            pub const CHOICES: &'static [(&'static str, &'static str)] = &[$(($s, concat!($($doc),+))),+];
            /// The option name of this variant.
            pub fn as_str(self) -> &'static str {
                match self { $($name::$v => $s),+ }
            }
        }
        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.as_str())
            }
        }
        impl $crate::shadow::options::OptionValue for $name {
            fn type_name() -> String {
                Self::NAMES.join("|")
            }
            fn parse(s: &str) -> Result<Self, $crate::error::Reason> {
                match s {
                    $($s => Ok($name::$v),)+
                    _ => Err(format!("is not one of {}", Self::NAMES.join(", ")).into()),
                }
            }
            fn choices() -> &'static [(&'static str, &'static str)] {
                Self::CHOICES
            }
        }
    };
}

/// An option type with a range: ordered, shown in messages, copied into the checks.
pub trait Number: OptionValue + PartialOrd + Copy + Send + Sync {}
impl<T: OptionValue + PartialOrd + Copy + Send + Sync> Number for T {}

type Setter<O> = Box<dyn Fn(&mut O, &str) -> Result<(), Reason> + Send + Sync>;
type Checker<O> = Box<dyn Fn(&O) -> Result<(), Reason> + Send + Sync>;
type Shower<O> = Box<dyn Fn(&O) -> String + Send + Sync>;

/// One option: key, documentation, type and range, and the struct field it maps to.
pub struct Field<O> {
    /// Key for `--set key=value`.
    pub key: &'static str,
    /// What it does.
    pub doc: &'static str,
    /// Type (and range) for `penumbra list`, e.g. `integer in [16, 16384]`.
    pub ty: String,
    /// The default, as text.
    pub default: String,
    /// For a choice, each value's name and meaning (empty otherwise).
    pub choices: &'static [(&'static str, &'static str)],
    set: Setter<O>,
    check: Checker<O>,
    show: Shower<O>,
}

impl<O: Clone + Default + 'static> Field<O> {
    /// A field of any value (no range).
    pub fn new<T: OptionValue>(key: &'static str, doc: &'static str, access: fn(&mut O) -> &mut T) -> Self {
        Field {
            key,
            doc,
            ty: T::type_name(),
            default: access(&mut O::default()).show(),
            choices: T::choices(),
            set: Box::new(move |o, s| {
                *access(o) = T::parse(s)?;
                Ok(())
            }),
            check: Box::new(|_| Ok(())),
            show: Box::new(move |o| access(&mut o.clone()).show()),
        }
    }

    /// The `size` field of a map, grid or texture side in texels: 16 to the pipeline's
    /// largest target side ([`crate::pipeline::MAX_DIMENSION`]).
    pub fn size(doc: &'static str, access: fn(&mut O) -> &mut u32) -> Self {
        Self::range("size", doc, 16, crate::pipeline::MAX_DIMENSION, access)
    }

    /// A numeric field that must lie in `[lo, hi]` (NaN never does).
    pub fn range<T: Number>(key: &'static str, doc: &'static str, lo: T, hi: T, access: fn(&mut O) -> &mut T) -> Self {
        Self::bounded(key, doc, (lo, true), hi, access)
    }

    /// A numeric field that must lie in `(lo, hi]`: above `lo`, at most `hi` (NaN never does).
    pub fn above<T: Number>(key: &'static str, doc: &'static str, lo: T, hi: T, access: fn(&mut O) -> &mut T) -> Self {
        Self::bounded(key, doc, (lo, false), hi, access)
    }

    /// A numeric field in `[lo, hi]` (`lo` included) or `(lo, hi]`; `penumbra list` and the
    /// error print the interval that is checked.
    fn bounded<T: Number>(
        key: &'static str,
        doc: &'static str,
        (lo, closed): (T, bool),
        hi: T,
        access: fn(&mut O) -> &mut T,
    ) -> Self {
        let open = if closed { '[' } else { '(' };
        let outside = move || -> Reason { format!("is outside {open}{lo}, {hi}]").into() };
        let inside = move |v: T| -> Result<(), Reason> {
            if (v > lo || (closed && v >= lo)) && v <= hi {
                Ok(())
            } else {
                Err(outside())
            }
        };
        // A number the type cannot hold (an integer's `inf`, `1e30` or `-1`, a float's `1e40`)
        // is outside the field's range too: the message gives that range, not the type's. (A
        // float's infinity keeps its own reason: infinities are never accepted.)
        let (lo_f, hi_f) = (lo.to_string().parse::<f64>(), hi.to_string().parse::<f64>());
        let integer = T::type_name() == "integer";
        let beyond = move |s: &str| match (s.trim().parse::<f64>(), &lo_f, &hi_f) {
            (Ok(x), Ok(l), Ok(h)) => (integer || x.is_finite()) && (x < *l || x > *h),
            _ => false,
        };
        Field {
            key,
            doc,
            ty: format!("{} in {open}{lo}, {hi}]", T::type_name()),
            default: access(&mut O::default()).show(),
            choices: &[],
            set: Box::new(move |o, s| {
                let v = T::parse(s).map_err(|e| if beyond(s) { outside() } else { e })?;
                inside(v)?;
                *access(o) = v;
                Ok(())
            }),
            check: Box::new(move |o| inside(*access(&mut o.clone()))),
            show: Box::new(move |o| access(&mut o.clone()).show()),
        }
    }
}

impl<I: Clone + Default + 'static> Field<I> {
    /// This field of a group of options `I` as a field of an options struct `O` that holds
    /// the group at `access` (the map pass's [`crate::shadow::light::MapOptions`], the
    /// lookups' [`crate::shadow::sample::lookup::Bias`]...): same key, documentation and range;
    /// its default is the one `O::default()` holds.
    pub fn within<O: Clone + Default + 'static>(self, access: fn(&mut O) -> &mut I) -> Field<O> {
        let Field {
            key,
            doc,
            ty,
            choices,
            set,
            check,
            show,
            ..
        } = self;
        Field {
            key,
            doc,
            ty,
            choices,
            default: show(access(&mut O::default())),
            set: Box::new(move |o, s| set(access(o), s)),
            check: Box::new(move |o| check(access(&mut o.clone()))),
            show: Box::new(move |o| show(access(&mut o.clone()))),
        }
    }
}

/// The fields of a group of options `I` ([`Field::within`]) as fields of `O`, which holds the
/// group at `access`.
pub fn within<O: Clone + Default + 'static, I: Clone + Default + 'static>(
    fields: impl IntoIterator<Item = Field<I>>,
    access: fn(&mut O) -> &mut I,
) -> Vec<Field<O>> {
    fields.into_iter().map(|f| f.within(access)).collect()
}

/// A technique's options: its name and fields. Parses `key=value` settings into the struct
/// and checks a struct built in code, with the same messages.
pub struct Declaration<O> {
    /// Technique name (for messages).
    pub technique: &'static str,
    /// The fields, in the order `penumbra list` prints them.
    pub fields: Vec<Field<O>>,
}

impl<O: Clone + Default + 'static> Declaration<O> {
    /// The declaration of technique `technique`'s options: `fields`, in the order `penumbra
    /// list` prints them.
    pub fn new(technique: &'static str, fields: Vec<Field<O>>) -> Self {
        Declaration { technique, fields }
    }

    /// `Options::default()` with `pairs` applied in order; errors name the technique, the
    /// option and what is wrong, and list the valid keys for an unknown one.
    pub fn parse(&self, pairs: &[(String, String)]) -> Result<O, Error> {
        let mut o = O::default();
        for (k, v) in pairs {
            let Some(f) = self.fields.iter().find(|f| f.key == k) else {
                let keys: Vec<&str> = self.fields.iter().map(|f| f.key).collect();
                return Err(self.error(
                    k,
                    v,
                    format!(
                        "is unknown (options: {})",
                        if keys.is_empty() {
                            "none".into()
                        } else {
                            keys.join(", ")
                        }
                    ),
                ));
            };
            (f.set)(&mut o, v).map_err(|e| self.error(k, v, e))?;
        }
        Ok(o)
    }

    /// Checks every ranged field of `o` (the library constructors call this).
    pub fn check(&self, o: &O) -> Result<(), Error> {
        for f in &self.fields {
            (f.check)(o).map_err(|e| self.error(f.key, &(f.show)(o), e))?;
        }
        Ok(())
    }

    /// An error of option `key` (given as `value`) of this technique.
    pub fn error(&self, key: &str, value: &str, message: impl Into<String>) -> Error {
        Error::option(key, value, message).in_technique(self.technique)
    }

    /// The settings of `o` that differ from the defaults, as `key=value` pairs.
    pub fn settings(&self, o: &O) -> Vec<(String, String)> {
        self.fields
            .iter()
            .filter_map(|f| {
                let v = (f.show)(o);
                (v != f.default).then(|| (f.key.to_string(), v))
            })
            .collect()
    }

    /// The declaration as plain rows (key, type, default, doc) for listings.
    pub fn infos(&self) -> Vec<OptionInfo> {
        self.fields
            .iter()
            .map(|f| OptionInfo {
                key: f.key,
                ty: f.ty.clone(),
                default: f.default.clone(),
                doc: f.doc,
                choices: f.choices.iter().map(|&(name, doc)| (name, doc.trim())).collect(),
            })
            .collect()
    }
}

/// One option as plain data: what `penumbra list` prints.
#[derive(Clone, Debug)]
pub struct OptionInfo {
    /// Key for `--set key=value`.
    pub key: &'static str,
    /// Type and range.
    pub ty: String,
    /// Default value, as text.
    pub default: String,
    /// What it does.
    pub doc: &'static str,
    /// For a choice, each value's name and meaning (empty otherwise).
    pub choices: Vec<(&'static str, &'static str)>,
}

impl OptionValue for crate::pipeline::DepthFormat {
    fn type_name() -> String {
        "f32|u24|u16".into()
    }
    fn parse(s: &str) -> Result<Self, Reason> {
        use crate::pipeline::DepthFormat as D;
        match s {
            "f32" => Ok(D::F32),
            "u24" => Ok(D::Unorm24),
            "u16" => Ok(D::Unorm16),
            _ => Err("is not one of f32, u24, u16".into()),
        }
    }
}

/// A depth format's option name.
impl Display for crate::pipeline::DepthFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        use crate::pipeline::DepthFormat as D;
        f.write_str(match self {
            D::F32 => "f32",
            D::Unorm24 => "u24",
            D::Unorm16 => "u16",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Clone, Debug, Default)]
    struct O {
        n: u32,
        x: f32,
        on: bool,
        name: String,
    }

    fn decl() -> Declaration<O> {
        Declaration::new(
            "t",
            vec![
                Field::range("n", "a count", 1, 8, |o: &mut O| &mut o.n),
                Field::range("x", "a number", -1.0, 1.0, |o: &mut O| &mut o.x),
                Field::new("on", "a switch", |o: &mut O| &mut o.on),
                Field::new("name", "words", |o: &mut O| &mut o.name),
            ],
        )
    }

    #[derive(Clone, Debug, Default)]
    struct Outer {
        inner: O,
        k: u32,
    }

    /// A group declared on its own type, nested with `within`: same keys and ranges, the
    /// outer struct's default, values set and checked in the group.
    #[test]
    fn fields_within_a_group_reach_it() {
        let outer_default = || Outer {
            inner: O { n: 3, ..O::default() },
            k: 0,
        };
        let d = Declaration::new("t", within(decl().fields, |o: &mut Outer| &mut o.inner));
        let infos = d.infos();
        assert_eq!(
            infos.iter().map(|i| i.key).collect::<Vec<_>>(),
            ["n", "x", "on", "name"]
        );
        // The default shown is `Outer::default()`'s (here the group's own default).
        assert_eq!(infos[0].default, "0");
        let o = d.parse(&pairs(&[("n", "5"), ("on", "true")])).unwrap();
        assert_eq!((o.inner.n, o.inner.on, o.k), (5, true, 0));
        let e = d.parse(&pairs(&[("n", "9")])).unwrap_err().to_string();
        assert!(e.contains("n=9") && e.contains("[1, 8]"), "{e}");
        let mut bad = outer_default();
        assert!(d.check(&bad).is_ok());
        bad.inner.x = 2.0;
        let e = d.check(&bad).unwrap_err().to_string();
        assert!(e.contains("x=2") && e.contains("[-1, 1]"), "{e}");
    }

    fn pairs(p: &[(&str, &str)]) -> Vec<(String, String)> {
        p.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect()
    }

    #[test]
    fn parse_check_and_messages() {
        let d = decl();
        let o = d
            .parse(&pairs(&[("n", "3"), ("x", "-0.5"), ("on", "on"), ("name", "a b")]))
            .unwrap();
        assert_eq!((o.n, o.x, o.on, o.name.as_str()), (3, -0.5, true, "a b"));
        assert_eq!(d.settings(&o).len(), 4);
        let err = |p: &[(&str, &str)]| d.parse(&pairs(p)).unwrap_err().to_string();
        for (key, value, message) in [
            ("n", "9", "is outside [1, 8]"),
            ("x", "NaN", "is not finite (NaN and infinities are not accepted)"),
            ("n", "two", "is not a number (an integer is expected)"),
            ("m", "1", "is unknown (options: n, x, on, name)"),
        ] {
            assert_eq!(
                err(&[(key, value)]),
                format!("technique 't': option {key}={value} {message}")
            );
        }
        assert!(err(&[("x", "-inf")]).ends_with("is not finite (NaN and infinities are not accepted)"));
        // A number past the type's limits but for the field's range: the range.
        assert!(err(&[("x", "1e39")]).ends_with("option x=1e39 is outside [-1, 1]"));
        // Regression: these all said "is not a number". Within the range, the type's reason;
        // outside it (even past what the type holds), the range.
        assert!(err(&[("n", "4e0")]).ends_with("is not written as an integer (write 4 in digits)"));
        assert!(err(&[("n", "2.5")]).ends_with("is not a whole number"));
        for v in ["-1", "1e3", "99999999999", "inf", "-inf"] {
            assert!(
                err(&[("n", v)]).ends_with(&format!("option n={v} is outside [1, 8]")),
                "{v}"
            );
        }
        assert!(err(&[("n", "nan")]).ends_with("is not a number"));
        assert!(err(&[("on", "yes")]).contains("is not one of true, false"));
        // The library path: a struct built in code is checked with the same message.
        let bad = O { n: 0, ..O::default() };
        assert_eq!(
            d.check(&bad).unwrap_err().to_string(),
            "technique 't': option n=0 is outside [1, 8]"
        );
        let infos = d.infos();
        assert_eq!(
            (infos[0].ty.as_str(), infos[0].default.as_str()),
            ("integer in [1, 8]", "0")
        );
    }
}
