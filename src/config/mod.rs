//! Machine profiles (`config/`) and themes (`themes/`), embedded in the binary
//! and patched field by field by the user's own files.
//!
//! Resolving a name (`--profile NAME`, `--theme NAME`):
//! 1. a path when it contains `/` or ends in `.toml`;
//! 2. otherwise `<config dir>/profiles/NAME.toml` (`themes/NAME.toml`) if it exists,
//!    the config dir being `$JOGTERM_CONFIG_DIR` or `~/.config/jogterm`;
//! 3. otherwise the shipped profile (theme) of that name.
//!
//! Every file patches another: the one named by its `base` key, else the shipped
//! `default` profile (`dark` theme). A broken file stops jogterm before anything
//! starts, with the file, line and what was expected.

pub mod macros;
pub mod probe;
pub mod profile;
pub mod source;
pub mod theme;
pub mod variant;

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;

pub use profile::{Profile, StartUnreferenced};
pub use source::{ConfigError, Origin, Source};
pub use theme::Theme;
pub use variant::{ProbeSurface, SimVariant};

/// Shipped profiles: name and TOML text.
pub const BUILTIN_PROFILES: &[(&str, &str)] = &[
    ("default", include_str!("../../config/default.toml")),
    ("isel", include_str!("../../config/isel.toml")),
    ("emcu", include_str!("../../config/emcu.toml")),
    ("emp", include_str!("../../config/emp.toml")),
    (
        "isel-rewired",
        include_str!("../../config/isel-rewired.toml"),
    ),
];

/// Shipped themes: name and TOML text.
pub const BUILTIN_THEMES: &[(&str, &str)] = &[
    ("dark", include_str!("../../themes/dark.toml")),
    ("light", include_str!("../../themes/light.toml")),
    ("mono16", include_str!("../../themes/mono16.toml")),
];

/// Where user configuration lives.
#[derive(Debug, Clone, Default)]
pub struct ConfigDirs {
    pub user: Option<PathBuf>,
}

impl ConfigDirs {
    /// `$JOGTERM_CONFIG_DIR`, else the platform config dir (`~/.config/jogterm`).
    pub fn from_env() -> Self {
        let user = std::env::var_os("JOGTERM_CONFIG_DIR")
            .map(PathBuf::from)
            .or_else(|| {
                directories::ProjectDirs::from("", "", "jogterm")
                    .map(|d| d.config_dir().to_path_buf())
            });
        Self { user }
    }

    /// Only the shipped files (tests, `--no-user-config`).
    pub fn builtin_only() -> Self {
        Self { user: None }
    }
}

struct Kind {
    what: &'static str,
    subdir: &'static str,
    builtin: &'static [(&'static str, &'static str)],
    root: &'static str,
}

const PROFILES: Kind = Kind {
    what: "profile",
    subdir: "profiles",
    builtin: BUILTIN_PROFILES,
    root: "default",
};
const THEMES: Kind = Kind {
    what: "theme",
    subdir: "themes",
    builtin: BUILTIN_THEMES,
    root: "dark",
};

/// Load a profile by name or path, validated.
pub fn load_profile(spec: &str, dirs: &ConfigDirs) -> Result<Profile, ConfigError> {
    load_profile_with_sources(spec, dirs).map(|(profile, _)| profile)
}

/// [`load_profile`], also returning the files it was layered from, most
/// specific first, so that checks made later (the UI's `[keys]` table) can
/// place their errors on the line that caused them
/// ([`source::error_for_key`]).
pub fn load_profile_with_sources(
    spec: &str,
    dirs: &ConfigDirs,
) -> Result<(Profile, Vec<Source>), ConfigError> {
    let (profile, sources, mut errors) = load_layered::<Profile>(spec, &PROFILES, dirs)?;
    let refs: Vec<&Source> = sources.iter().collect();
    // Every problem at once: the fields serde refused, then the checks of
    // the (repaired) profile as a whole.
    if let Some(profile) = &profile {
        errors.extend(
            profile
                .validate()
                .into_iter()
                .map(|problem| match problem.offset {
                    Some(offset) => {
                        source::error_in_string(&refs, &problem.key, offset, problem.message)
                    }
                    None => source::error_for_key(&refs, &problem.key, problem.message),
                }),
        );
    }
    match (profile, ConfigError::all(errors)) {
        (_, Some(errors)) => Err(errors),
        (Some(mut profile), None) => {
            profile.retain_listed_axes();
            Ok((profile, sources))
        }
        (None, None) => Err(ConfigError::new(
            sources
                .first()
                .map_or(Origin::Embedded("profile"), |s| s.origin.clone()),
            "the profile cannot be read",
        )),
    }
}

/// Load a theme by name or path.
pub fn load_theme(spec: &str, dirs: &ConfigDirs) -> Result<Theme, ConfigError> {
    let (theme, sources, errors) = load_layered::<Theme>(spec, &THEMES, dirs)?;
    match (theme, ConfigError::all(errors)) {
        (Some(theme), None) => Ok(theme),
        (_, Some(errors)) => Err(errors),
        (None, None) => Err(ConfigError::new(
            sources
                .first()
                .map_or(Origin::Embedded("theme"), |s| s.origin.clone()),
            "the theme cannot be read",
        )),
    }
}

/// Names of shipped and user profiles (for `--help` texts and error messages).
pub fn profile_names(dirs: &ConfigDirs) -> Vec<String> {
    names(&PROFILES, dirs)
}

pub fn theme_names(dirs: &ConfigDirs) -> Vec<String> {
    names(&THEMES, dirs)
}

fn names(kind: &Kind, dirs: &ConfigDirs) -> Vec<String> {
    let mut out: Vec<String> = kind.builtin.iter().map(|(n, _)| n.to_string()).collect();
    if let Some(dir) = dirs.user.as_ref().map(|d| d.join(kind.subdir))
        && let Ok(entries) = std::fs::read_dir(dir)
    {
        for entry in entries.flatten() {
            let path = entry.path();
            if path.extension().is_some_and(|e| e == "toml")
                && let Some(stem) = path.file_stem().and_then(|s| s.to_str())
                && !out.iter().any(|n| n == stem)
            {
                out.push(stem.to_string());
            }
        }
    }
    out
}

/// Read `spec` and the chain of files it patches, most specific first, merge
/// them onto the root and deserialize: the value (repaired where fields were
/// wrong, `None` when it could not be), the sources, and every field's error
/// (`source::deserialize_all`). A file that cannot be read or parsed is the
/// error itself.
#[allow(clippy::type_complexity)]
fn load_layered<T: DeserializeOwned>(
    spec: &str,
    kind: &Kind,
    dirs: &ConfigDirs,
) -> Result<(Option<T>, Vec<Source>, Vec<ConfigError>), ConfigError> {
    const MAX_DEPTH: usize = 8;
    let mut chain: Vec<(Source, toml::Table)> = Vec::new();
    let mut next = Some(spec.to_string());
    while let Some(name) = next.take() {
        let src = resolve(&name, kind, dirs, chain.last().map(|(s, _)| s))?;
        if chain.iter().any(|(s, _)| s.origin == src.origin) {
            return Err(ConfigError::new(
                src.origin,
                format!("`base` chain loops back to this {}", kind.what),
            ));
        }
        if chain.len() >= MAX_DEPTH {
            return Err(ConfigError::new(
                src.origin,
                format!("`base` chain is deeper than {MAX_DEPTH} files"),
            ));
        }
        let table = source::parse_table(&src)?;
        let base = match table.get("base") {
            Some(toml::Value::String(b)) => Some(b.clone()),
            Some(_) => {
                return Err(ConfigError::at_key(
                    &src,
                    &["base".into()],
                    "`base` must be the name of another file",
                ));
            }
            None if src.origin == Origin::Embedded(kind.root) => None,
            None => Some(kind.root.to_string()),
        };
        chain.push((src, table));
        next = base;
    }
    let mut merged = toml::Table::new();
    let mut sources = Vec::with_capacity(chain.len());
    let mut root: Option<toml::Table> = None;
    for (src, table) in chain.into_iter().rev() {
        if root.is_none() && src.origin == Origin::Embedded(kind.root) {
            root = Some(table.clone());
        }
        source::merge(&mut merged, table);
        sources.push(src);
    }
    sources.reverse();
    let refs: Vec<&Source> = sources.iter().collect();
    let (value, errors) = source::deserialize_all::<T>(merged, root.as_ref(), &refs);
    Ok((value, sources, errors))
}

/// Largest configuration file jogterm reads. Profiles and themes are a few
/// KiB; the bound keeps a wrong path (`base = "/dev/zero"`, a log file) from
/// filling memory before the error is reported.
pub const MAX_FILE_BYTES: u64 = 1 << 20;

/// The text of a configuration file, at most [`MAX_FILE_BYTES`].
fn read_text(path: &Path) -> std::io::Result<String> {
    use std::io::{Error, ErrorKind, Read};
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(Error::new(
            ErrorKind::InvalidData,
            format!("larger than {} KiB", MAX_FILE_BYTES / 1024),
        ));
    }
    String::from_utf8(bytes)
        .map_err(|_| Error::new(ErrorKind::InvalidData, "stream did not contain valid UTF-8"))
}

fn resolve(
    name: &str,
    kind: &Kind,
    dirs: &ConfigDirs,
    referrer: Option<&Source>,
) -> Result<Source, ConfigError> {
    let read = |path: &Path| -> Result<Source, ConfigError> {
        read_text(path)
            .map(|text| Source {
                origin: Origin::File(path.to_path_buf()),
                text,
            })
            .map_err(|e| {
                ConfigError::new(
                    Origin::File(path.to_path_buf()),
                    format!("cannot read {} file: {e}", kind.what),
                )
            })
    };
    if name.contains('/') || name.ends_with(".toml") {
        return read(Path::new(name));
    }
    // A user file may patch the shipped file of the same name: `base = "dark"`
    // in ~/.config/jogterm/themes/dark.toml must reach the embedded one.
    let from_user_file = matches!(referrer.map(|s| &s.origin), Some(Origin::File(_)));
    if let Some(path) = dirs
        .user
        .as_ref()
        .map(|d| d.join(kind.subdir).join(format!("{name}.toml")))
        && path.is_file()
        && !(from_user_file && referrer.map(|s| &s.origin) == Some(&Origin::File(path.clone())))
    {
        return read(&path);
    }
    kind.builtin
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(n, text)| Source {
            origin: Origin::Embedded(n),
            text: text.to_string(),
        })
        .ok_or_else(|| {
            // `base` naming its own file reaches past it for a shipped file
            // of that name (above); without one, "no such name" would list
            // the very file the operator is looking at.
            if let Some(src) = referrer.filter(|s| {
                matches!(&s.origin, Origin::File(p) if p.file_stem().is_some_and(|stem| stem == name))
            }) {
                return ConfigError::at_key(
                    src,
                    &["base".into()],
                    format!(
                        "`base = \"{name}\"` names this file itself; a {what} file may patch a \
                         shipped {what} of its own name, and none is called `{name}` (shipped: {shipped})",
                        what = kind.what,
                        shipped = kind.builtin.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", "),
                    ),
                );
            }
            let known = names(kind, dirs).join(", ");
            let origin = referrer
                .map(|s| s.origin.clone())
                .unwrap_or(Origin::File(PathBuf::from(name)));
            ConfigError::new(
                origin,
                format!("no {} named `{name}` (known: {known})", kind.what),
            )
        })
}

#[cfg(test)]
mod tests;
