//! The parameter profiles pmon ships: partial TOML files over the defaults, each with what it buys and costs in
//! its comments (README, "The recall profile"). Every front end loads them by the same name: `--params
//! profile:NAME` on the `pmon` command, `pmon_monitor_new_from_file("profile:NAME", ...)` in the C API,
//! `Params.profile("NAME")` or `params="profile:NAME"` in Python. A file whose name begins with `profile:` is
//! given as `./profile:...`.

/// The profiles: name and TOML text (`crates/session/profiles/NAME.toml`).
pub const PROFILES: &[(&str, &str)] = &[("recall", include_str!("../profiles/recall.toml"))];

/// The profile name a parameter path names (`profile:NAME`), if it names one. `None` for a file path.
#[must_use]
pub fn profile_name(path: &str) -> Option<&str> {
    path.strip_prefix("profile:")
}

/// The TOML text of the profile `name`, or an error that lists the profiles there are.
///
/// # Errors
/// An unknown name (the message names the shipped profiles and how to give a file of that name).
pub fn profile_toml(name: &str) -> Result<&'static str, String> {
    PROFILES.iter().find(|(n, _)| *n == name).map(|(_, text)| *text).ok_or_else(|| {
        let names: Vec<String> = PROFILES.iter().map(|(n, _)| format!("profile:{n}")).collect();
        format!(
            "unknown parameter profile `{name}`: pmon ships {} (a file of that name: `./profile:{name}`)",
            names.join(", ")
        )
    })
}

/// The names of the shipped profiles, in order.
pub fn profile_names() -> impl Iterator<Item = &'static str> {
    PROFILES.iter().map(|(n, _)| *n)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn names_and_unknown_names() {
        assert_eq!(profile_name("profile:recall"), Some("recall"));
        assert_eq!(profile_name("./profile:recall"), None);
        assert_eq!(profile_name("params.toml"), None);
        assert!(profile_toml("recall").unwrap().contains("returns_beyond_cells = 1"));
        let e = profile_toml("fast").unwrap_err();
        assert!(e.contains("unknown parameter profile `fast`") && e.contains("profile:recall"), "{e}");
        assert_eq!(profile_names().collect::<Vec<_>>(), ["recall"]);
    }
}
