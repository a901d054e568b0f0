//! The choices of a fit as the command line and the Python API give them: the number of
//! Gaussians (`N`, `auto`, `auto:MAX`) and of starts, parsed from text with the same messages.

use crate::material::mixture::fit::MAX_RESTARTS;

/// Default maximum of `--components auto`.
pub const AUTO_MAX_COMPONENTS: usize = 8;

/// `--components`: a number of Gaussians, or the maximum of an automatic choice.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Components {
    pub count: usize,
    pub auto: bool,
}

impl std::fmt::Display for Components {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.auto {
            write!(f, "auto:{}", self.count)
        } else {
            write!(f, "{}", self.count)
        }
    }
}

/// `N`, `auto` (up to [`AUTO_MAX_COMPONENTS`]) or `auto:MAX`, with N and MAX in 1..=32.
pub fn parse_components(s: &str) -> Result<Components, String> {
    let max = crate::material::mixture::conditional::MAX_COMPONENTS;
    let (text, auto) = match s.strip_prefix("auto") {
        Some("") => {
            return Ok(Components {
                count: AUTO_MAX_COMPONENTS,
                auto: true,
            });
        }
        Some(rest) => match rest.strip_prefix(':') {
            Some(m) => (m, true),
            None => return Err("expected a number of Gaussians, `auto` or `auto:MAX`".into()),
        },
        None => (s, false),
    };
    let what = if auto {
        "the maximum number of Gaussians"
    } else {
        "the number of Gaussians"
    };
    match text.parse::<usize>() {
        Ok(count) if (1..=max).contains(&count) => Ok(Components { count, auto }),
        Ok(_) => Err(format!("{what} must be in 1..={max}")),
        Err(_) => Err("expected a number of Gaussians, `auto` or `auto:MAX`".into()),
    }
}

/// `--restarts`: 1..=[`MAX_RESTARTS`].
pub fn parse_restarts(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if (1..=MAX_RESTARTS).contains(&n) => Ok(n),
        _ => Err(format!(
            "the number of starts must be in 1..={MAX_RESTARTS}"
        )),
    }
}
