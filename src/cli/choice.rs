//! One value parser for the core's enums of named choices, with clap's possible values and errors.

use crate::integrator::{
    IntegratorKind, LaneWeighting, LightWavelengths, MisHeuristic, ResetChoice,
};
use crate::material::WavelengthSampling;
use crate::material::mixture::{FitMethod, ScaleMethod};
use crate::medium::Tracking;
use crate::spectrum::cie::CameraWavelengths;
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use std::ffi::OsStr;
use std::marker::PhantomData;

/// An enum of the core declared with `named_enum!`: its variants, each with its name and doc
/// comment, as the command line offers them.
pub trait Choice: Copy + Send + Sync + 'static {
    /// Every variant, in order.
    fn all() -> &'static [Self];
    /// The name on the command line (and in configs).
    fn name(self) -> &'static str;
    /// The doc comment, one line per line (empty without one).
    fn help(self) -> &'static str;
}

/// `Choice` for core enums, from the items `named_enum!` gives them.
macro_rules! choices {
    ($($t:ty),+ $(,)?) => {$(
        impl Choice for $t {
            fn all() -> &'static [Self] {
                &<$t>::ALL
            }
            fn name(self) -> &'static str {
                <$t>::name(self)
            }
            fn help(self) -> &'static str {
                <$t>::help(self)
            }
        }
    )+};
}

choices!(
    CameraWavelengths,
    FitMethod,
    IntegratorKind,
    LaneWeighting,
    LightWavelengths,
    MisHeuristic,
    ResetChoice,
    ScaleMethod,
    Tracking,
    WavelengthSampling,
);

/// The value parser of an option whose values are the variants of `T`.
pub fn choice<T: Choice>() -> ChoiceParser<T> {
    ChoiceParser(PhantomData)
}

/// Parses a variant of `T` by its name. Its possible values, their help (a variant's doc comment
/// as clap's derive shows it) and its errors (`invalid value 'x' for '--opt <OPT>'`, the possible
/// values, a similar one as a tip) are those of clap's own enum parser.
#[derive(Clone, Copy, Debug)]
pub struct ChoiceParser<T>(PhantomData<T>);

impl<T: Choice> ChoiceParser<T> {
    fn possible_values() -> impl Iterator<Item = PossibleValue> {
        T::all().iter().map(|&v| {
            let help = help_line(v.help());
            let value = PossibleValue::new(v.name());
            if help.is_empty() {
                value
            } else {
                value.help(help)
            }
        })
    }
}

impl<T: Choice> TypedValueParser for ChoiceParser<T> {
    type Value = T;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &OsStr,
    ) -> Result<T, clap::Error> {
        // A value that is not UTF-8 is an invalid value, shown lossily, as clap's enum parser
        // reports it (it matches no name).
        let value = value.to_string_lossy();
        let given = PossibleValuesParser::new(Self::possible_values()).parse_ref(
            cmd,
            arg,
            OsStr::new(value.as_ref()),
        )?;
        let ignore_case = arg.is_some_and(clap::Arg::is_ignore_case_set);
        let (variant, _) = T::all()
            .iter()
            .zip(Self::possible_values())
            .find(|(_, p)| p.matches(&given, ignore_case))
            .expect("the names parser accepts only possible values");
        Ok(*variant)
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(Box::new(Self::possible_values()))
    }
}

/// A doc comment as clap's derive shows a variant's: the lines of its first paragraph trimmed
/// and joined by spaces, without a final period (but an ellipsis kept).
fn help_line(doc: &str) -> String {
    let line = doc
        .lines()
        .map(str::trim)
        .skip_while(|l| l.is_empty())
        .take_while(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(" ");
    match line.strip_suffix('.') {
        Some(s) if !line.ends_with("..") => s.to_string(),
        _ => line,
    }
}

#[cfg(test)]
mod tests {
    use super::help_line;

    #[test]
    fn help_lines_are_formed_as_clap_forms_doc_comments() {
        assert_eq!(help_line(" One line.\n"), "One line");
        assert_eq!(help_line(" Two lines,\n  joined.\n"), "Two lines, joined");
        assert_eq!(help_line(" Etc...\n"), "Etc...");
        assert_eq!(help_line(" No period\n"), "No period");
        assert_eq!(help_line("\n First.\n\n Second.\n"), "First");
        assert_eq!(help_line(""), "");
    }
}
