//! The configuration loader: a user's profile or theme file, layered over
//! the shipped ones, and what jogterm builds from a profile that loaded.

use std::path::PathBuf;

use jogterm::config::{ConfigDirs, ConfigError, load_profile_with_sources, load_theme};
use jogterm::program::LintConfig;
use jogterm::sim::registry;
use jogterm::ui::Setup;
use jogterm::ui::keymap::Keymap;
use jogterm::ui::palette::Palette;

use super::split_head;

/// A configuration directory of this thread's own (tests of one binary run
/// in parallel threads), with `profiles/` and `themes/`.
fn config_dir() -> PathBuf {
    let thread = format!("{:?}", std::thread::current().id())
        .chars()
        .filter(char::is_ascii_alphanumeric)
        .collect::<String>();
    let dir = std::env::temp_dir().join(format!(
        "jogterm-fuzz-config-{}-{thread}",
        std::process::id()
    ));
    for sub in ["profiles", "themes"] {
        let _ = std::fs::create_dir_all(dir.join(sub));
    }
    dir
}

/// The first byte picks profile or theme; the rest is the file's text
/// (invalid UTF-8 replaced: the loader reads text).
pub fn config(data: &[u8]) {
    let (head, body) = split_head(data);
    let text = String::from_utf8_lossy(body);
    let dir = config_dir();
    let dirs = ConfigDirs {
        user: Some(dir.clone()),
    };
    if head & 1 == 0 {
        let file = dir.join("profiles").join("fuzz.toml");
        std::fs::write(&file, text.as_bytes()).expect("write the profile");
        match load_profile_with_sources(&file.to_string_lossy(), &dirs) {
            Ok((profile, sources)) => {
                // Everything jogterm builds from a profile it accepted.
                let refs: Vec<_> = sources.iter().collect();
                let keymap = Keymap::builtin().expect("built-in keys");
                let macros: Vec<&str> = profile.macros.keys().map(String::as_str).collect();
                let _ = keymap.with_overrides(&profile.keys, &macros, &refs);
                let _ = registry::build(profile.connection.protocol, &profile);
                let _ = LintConfig::from_profile(&profile);
                let _ = Setup::from_profile(&profile, None);
                let _ = profile.connection.line();
            }
            Err(e) => check_error(&e, &text),
        }
    } else {
        let file = dir.join("themes").join("fuzz.toml");
        std::fs::write(&file, text.as_bytes()).expect("write the theme");
        match load_theme(&file.to_string_lossy(), &dirs) {
            Ok(theme) => {
                let _ = Palette::from(&theme);
            }
            Err(e) => check_error(&e, &text),
        }
    }
}

/// An error names a place that exists in the file it blames.
fn check_error(e: &ConfigError, text: &str) {
    let message = e.to_string();
    assert!(!message.is_empty());
    if let (Some(line), jogterm::config::Origin::File(path)) = (e.line, &e.origin)
        && path.ends_with("fuzz.toml")
    {
        let lines = text.split('\n').count();
        assert!(
            line >= 1 && line <= lines,
            "line {line} of {lines}: {message}"
        );
    }
}
