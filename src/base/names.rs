//! The one spelling rule for closed choices (detectors, BRDFs, cullings, formats, scenes, …): every enum lists
//! its variants once, with one kebab-case name each, and everything else — the CLI parser and its `--help`
//! values, error messages, `Display`, `FromStr` — is derived from that list.
//!
//! The rule: a name is matched ignoring ASCII case, white space and the separators `-` and `_` ([`normalize`]):
//! `blinn-phong`, `Blinn_Phong` and `BlinnPhong` are one BRDF, `RGBA8_SRGB` and `rgba8-srgb` one format. Enums declare themselves with [`named_enum!`](crate::named_enum) (or implement [`Named`] by
//! hand where a variant carries data); clap picks the parser up through `ValueParserFactory`, so a flag of an
//! enum type needs no `value_parser` attribute.

#[cfg(feature = "cli")]
use clap::builder::{PossibleValue, TypedValueParser};
#[cfg(feature = "cli")]
use std::ffi::OsStr;
#[cfg(feature = "cli")]
use std::marker::PhantomData;

/// A closed choice with one name per value.
pub trait Named: Copy + PartialEq + Send + Sync + 'static {
    /// What the choice is, for messages ("detector", "BRDF").
    const KIND: &'static str;

    /// Every value, in the order lists show them.
    fn all() -> &'static [Self];

    /// The one spelling.
    fn name(self) -> &'static str;

    /// The value whose name matches `s` under the crate's one rule ([`normalize`]).
    #[must_use]
    fn from_name(s: &str) -> Option<Self> {
        let s = normalize(s);
        Self::all().iter().copied().find(|v| normalize(v.name()) == s)
    }

    /// Every name, comma-separated (for messages).
    #[must_use]
    fn names() -> String {
        Self::all().iter().map(|v| v.name()).collect::<Vec<_>>().join(", ")
    }

    /// Parses `s`, or says what was expected: `unknown BRDF "gxx"; did you mean "ggx"? (known: lambert,
    /// blinn-phong, ggx)`.
    fn parse(s: &str) -> Result<Self, String> {
        Self::from_name(s).ok_or_else(|| {
            let names: Vec<&str> = Self::all().iter().map(|v| v.name()).collect();
            unknown(Self::KIND, s, &names, &Self::names())
        })
    }
}

/// The one of `known` that `input` most likely misspells: the nearest under the spelling rule ([`normalize`]) by
/// edit distance, when that distance is small for the name's length (at most a third of it, 1 to 3 edits), or
/// the only name that `input` starts or ends. `None` when nothing is close.
#[must_use]
pub fn closest<'a>(input: &str, known: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let want = normalize(input);
    if want.is_empty() {
        return None;
    }
    let known: Vec<&str> = known.into_iter().collect();
    let limit = (want.chars().count() / 3).clamp(1, 3);
    let best = known
        .iter()
        .map(|k| (edit_distance(&want, &normalize(k)), *k))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, _)| *d)
        .map(|(_, k)| k);
    best.or_else(|| {
        let mut partial = known.iter().filter(|k| {
            let k = normalize(k);
            k.starts_with(&want) || want.starts_with(&k) || k.ends_with(&want)
        });
        match (partial.next(), partial.next()) {
            (Some(one), None) => Some(*one),
            _ => None,
        }
    })
}

/// The message for a name not among `known`: a suggestion when one is close ([`closest`]), and `listing` (the
/// names, or a shorter way to say them) unless a suggestion stands in for a long list.
#[must_use]
pub fn unknown(kind: &str, input: &str, known: &[&str], listing: &str) -> String {
    match closest(input, known.iter().copied()) {
        Some(s) if listing.len() > 200 => {
            format!("unknown {kind} {input:?}; did you mean {s:?}? ({} valid names in all)", known.len())
        }
        Some(s) => format!("unknown {kind} {input:?}; did you mean {s:?}? (known: {listing})"),
        None => format!("unknown {kind} {input:?}; known: {listing}"),
    }
}

/// Levenshtein distance between two strings, by characters.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diag = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let next = (row[j + 1] + 1).min(row[j] + 1).min(diag + usize::from(ca != *cb));
            diag = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

/// The spelling rule: ASCII lower case without white space, `-` or `_`.
#[must_use]
pub fn normalize(s: &str) -> String {
    s.chars().filter(|c| !matches!(c, '-' | '_') && !c.is_whitespace()).collect::<String>().to_ascii_lowercase()
}

/// The clap parser of every [`Named`] type: parses by [`Named::from_name`] and lists [`Named::all`] as the
/// possible values (shown by `--help` and shell completion). With the `cli` feature.
#[cfg(feature = "cli")]
#[derive(Clone, Copy, Debug)]
pub struct NameParser<T>(PhantomData<fn() -> T>);

#[cfg(feature = "cli")]
impl<T> Default for NameParser<T> {
    fn default() -> Self {
        NameParser(PhantomData)
    }
}

#[cfg(feature = "cli")]
impl<T: Named> TypedValueParser for NameParser<T> {
    type Value = T;

    fn parse_ref(&self, cmd: &clap::Command, arg: Option<&clap::Arg>, value: &OsStr) -> Result<T, clap::Error> {
        use clap::error::{ContextKind, ContextValue, ErrorKind};
        let s = value.to_string_lossy();
        T::from_name(&s).ok_or_else(|| {
            let mut err = clap::Error::new(ErrorKind::InvalidValue).with_cmd(cmd);
            let flag = arg.map_or_else(|| "value".to_string(), ToString::to_string);
            err.insert(ContextKind::InvalidArg, ContextValue::String(flag));
            let near = closest(&s, T::all().iter().map(|v| v.name()));
            err.insert(ContextKind::InvalidValue, ContextValue::String(s.into_owned()));
            let names: Vec<String> = T::all().iter().map(|v| v.name().to_string()).collect();
            if let Some(near) = near {
                err.insert(ContextKind::SuggestedValue, ContextValue::String(near.to_string()));
            }
            err.insert(ContextKind::ValidValue, ContextValue::Strings(names));
            err
        })
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(Box::new(T::all().iter().map(|v| PossibleValue::new(v.name()))))
    }
}

/// Implements the name machinery for an enum declared by hand (one whose variants carry no data):
/// `ALL`, `name()`, `from_name()`, [`Named`] (with `names()` and `parse()`), `Display`, `FromStr` and clap's
/// `ValueParserFactory`.
///
/// ```ignore
/// named!(Brdf: "BRDF" { Lambert => "lambert", BlinnPhong => "blinn-phong" });
/// ```
#[macro_export]
#[doc(hidden)]
macro_rules! named {
    ($name:ident : $kind:literal { $($variant:ident => $text:literal),+ $(,)? }) => {
        impl $name {
            /// Every variant, in the order lists show them.
            pub const ALL: [$name; [$($name::$variant),+].len()] = [$($name::$variant),+];

            /// The one kebab-case spelling (flags, JSON, file names).
            #[must_use]
            pub fn name(self) -> &'static str {
                match self {
                    $($name::$variant => $text),+
                }
            }

            /// Parses a spelling of [`Self::name`] under the crate's one rule (`base::names::normalize`).
            #[must_use]
            pub fn from_name(s: &str) -> Option<Self> {
                <Self as $crate::base::names::Named>::from_name(s)
            }
        }

        impl $crate::base::names::Named for $name {
            const KIND: &'static str = $kind;
            fn all() -> &'static [Self] {
                &Self::ALL
            }
            fn name(self) -> &'static str {
                $name::name(self)
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl std::str::FromStr for $name {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, String> {
                <Self as $crate::base::names::Named>::parse(s)
            }
        }

        #[cfg(feature = "cli")]
        impl clap::builder::ValueParserFactory for $name {
            type Parser = $crate::base::names::NameParser<$name>;
            fn value_parser() -> Self::Parser {
                $crate::base::names::NameParser::default()
            }
        }
    };
}

/// Declares an enum whose variants carry no data, with its names ([`named!`](crate::named)): the attributes
/// (derives, serde renames, docs) pass through, and each variant is followed by `=> "its-name"`.
///
/// ```ignore
/// named_enum! {
///     /// How lights are matched to samples.
///     #[derive(Clone, Copy, Debug, PartialEq, Eq)]
///     pub enum Culling: "culling" {
///         /// Every light against every sample.
///         None => "none",
///         Tiled => "tiled",
///     }
/// }
/// ```
#[macro_export]
#[doc(hidden)]
macro_rules! named_enum {
    ($(#[$meta:meta])* pub enum $name:ident : $kind:literal {
        $($(#[$vmeta:meta])* $variant:ident => $text:literal),+ $(,)?
    }) => {
        $(#[$meta])*
        pub enum $name {
            $($(#[$vmeta])* $variant),+
        }
        $crate::named!($name: $kind { $($variant => $text),+ });
    };
}

pub use crate::{named, named_enum};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_typo_gets_the_name_it_misspells_and_a_stranger_gets_none() {
        let layouts = ["fat-20", "rgba16f-2x", "lauritzen-15", "destiny-96", "unreal-like", "minimal-8"];
        assert_eq!(closest("lauritzen15", layouts), Some("lauritzen-15"));
        assert_eq!(closest("destiny96", layouts), Some("destiny-96"));
        assert_eq!(closest("unreal", layouts), Some("unreal-like"));
        assert_eq!(closest("minmal-8", layouts), Some("minimal-8"));
        assert_eq!(closest("fat-21", layouts), Some("fat-20"));
        assert_eq!(closest("gbuffer", layouts), None);
        assert_eq!(closest("", layouts), None);
        assert_eq!(closest("gxx", ["lambert", "blinn-phong", "ggx"]), Some("ggx"));
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        let long = "x".repeat(300);
        let m = unknown("codec", "octahedrl-16", &["octahedral-16", "octahedral-24"], &long);
        assert!(m.contains("did you mean \"octahedral-16\"") && !m.contains(&long), "{m}");
        let m = unknown("BRDF", "phong2", &["lambert", "ggx"], "lambert, ggx");
        assert_eq!(m, "unknown BRDF \"phong2\"; known: lambert, ggx");
    }
    #[cfg(feature = "cli")]
    use clap::Parser;

    crate::named_enum! {
        /// A test choice.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum Fruit: "fruit" {
            /// Red.
            Apple => "apple",
            /// Long.
            BlueBanana => "blue-banana",
        }
    }

    #[cfg(feature = "cli")]
    #[derive(Parser, Debug)]
    struct Cli {
        #[arg(long, default_value = "apple")]
        fruit: Fruit,
    }

    #[test]
    fn one_rule_for_every_spelling() {
        assert_eq!(Fruit::ALL, [Fruit::Apple, Fruit::BlueBanana]);
        for s in ["blue-banana", "Blue_Banana", " BLUE-banana ", "BlueBanana"] {
            assert_eq!(Fruit::from_name(s), Some(Fruit::BlueBanana), "{s}");
        }
        assert_eq!(Fruit::from_name("blue-bananas"), None);
        assert_eq!("apple".parse::<Fruit>(), Ok(Fruit::Apple));
        assert_eq!(Fruit::parse("kiwi").unwrap_err(), "unknown fruit \"kiwi\"; known: apple, blue-banana");
        assert_eq!(Fruit::BlueBanana.to_string(), "blue-banana");
    }

    #[cfg(feature = "cli")]
    #[test]
    fn clap_parses_and_lists_the_names() {
        assert_eq!(Cli::try_parse_from(["x"]).unwrap().fruit, Fruit::Apple);
        assert_eq!(Cli::try_parse_from(["x", "--fruit", "BLUE_BANANA"]).unwrap().fruit, Fruit::BlueBanana);
        let err = Cli::try_parse_from(["x", "--fruit", "kiwi"]).unwrap_err();
        assert_eq!(err.kind(), clap::error::ErrorKind::InvalidValue);
        let err = err.to_string();
        assert!(err.contains("'kiwi'") && err.contains("apple, blue-banana"), "{err}");
        let help = <Cli as clap::CommandFactory>::command().render_long_help().to_string();
        assert!(help.contains("blue-banana"), "{help}");
    }
}
