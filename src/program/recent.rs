//! The files opened last in the console (issue 40): the Ctrl-O form offers
//! them with Up and Down. One path a line in the state directory's
//! `recent-files`, newest first. The list is pure (`with`, `parse`,
//! `text`); `read` and `write` are the thin file layer, run at start-up and
//! on the editor's file worker.
//!
//! Only paths that opened are kept, as absolute paths, so that a list read
//! in another working directory still names the same files. A line that is
//! no absolute path (a hand edit, a torn write) is left out, never an error:
//! the list is a convenience, and a broken one must not keep the console
//! from starting.

use std::path::{Path, PathBuf};

use super::store::{StoreError, write_atomically};

/// How many files the list keeps.
pub const KEEP: usize = 10;

/// The list's file in the state directory.
pub const FILE_NAME: &str = "recent-files";

/// `list` with `opened` first and any older mention of it removed.
pub fn with(list: &[PathBuf], opened: &Path) -> Vec<PathBuf> {
    std::iter::once(opened.to_path_buf())
        .chain(list.iter().filter(|p| p.as_path() != opened).cloned())
        .take(KEEP)
        .collect()
}

/// The list a file holds: absolute paths, once each, at most [`KEEP`].
pub fn parse(text: &str) -> Vec<PathBuf> {
    let mut list: Vec<PathBuf> = Vec::new();
    for line in text.lines().map(str::trim_end) {
        let path = PathBuf::from(line);
        if !line.is_empty() && path.is_absolute() && !list.contains(&path) {
            list.push(path);
        }
    }
    list.truncate(KEEP);
    list
}

/// The file's text for `list`. A path with a line break in its name cannot
/// be kept on one line and is left out.
pub fn text(list: &[PathBuf]) -> String {
    list.iter()
        .filter_map(|p| p.to_str())
        .filter(|p| !p.contains(['\n', '\r']))
        .map(|p| format!("{p}\n"))
        .collect()
}

/// The list kept in `dir`; empty when there is none or it cannot be read.
pub fn read(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_to_string(dir.join(FILE_NAME))
        .map(|t| parse(&t))
        .unwrap_or_default()
}

/// Keep `list` in `dir` (created if missing), replacing the file whole.
pub fn write(dir: &Path, list: &[PathBuf]) -> Result<(), StoreError> {
    std::fs::create_dir_all(dir).map_err(|source| StoreError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    write_atomically(&dir.join(FILE_NAME), text(list).as_bytes(), 0o600)
}

/// The entry after (`step` 1) or before (`step` -1) `current` in `list`,
/// wrapping; the first (or last) when `current` is not in it.
pub fn step(list: &[PathBuf], current: &str, step: isize) -> Option<PathBuf> {
    let n = list.len();
    if n == 0 {
        return None;
    }
    let at = list.iter().position(|p| p.as_os_str() == current);
    let next = match (at, step >= 0) {
        (Some(i), true) => (i + 1) % n,
        (Some(i), false) => (i + n - 1) % n,
        (None, true) => 0,
        (None, false) => n - 1,
    };
    list.get(next).cloned()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paths(names: &[&str]) -> Vec<PathBuf> {
        names.iter().map(PathBuf::from).collect()
    }

    #[test]
    fn the_file_opened_goes_first_once_and_the_list_keeps_ten() {
        let list = paths(&["/a.nc", "/b.nc", "/c.nc"]);
        assert_eq!(
            with(&list, Path::new("/b.nc")),
            paths(&["/b.nc", "/a.nc", "/c.nc"])
        );
        let mut long = Vec::new();
        for k in 0..15 {
            long = with(&long, Path::new(&format!("/{k}.nc")));
        }
        assert_eq!(long.len(), KEEP);
        assert_eq!(long[0], PathBuf::from("/14.nc"));
    }

    #[test]
    fn a_broken_file_gives_what_it_can_and_never_fails() {
        let list = parse("/a.nc\nrelative.nc\n\n/a.nc\n/b c.nc\n");
        assert_eq!(list, paths(&["/a.nc", "/b c.nc"]));
        assert_eq!(parse(&text(&list)), list);
        assert!(parse("").is_empty());
    }

    #[test]
    fn up_and_down_walk_the_list_and_wrap() {
        let list = paths(&["/a.nc", "/b.nc"]);
        assert_eq!(step(&list, "", 1), Some(PathBuf::from("/a.nc")));
        assert_eq!(step(&list, "", -1), Some(PathBuf::from("/b.nc")));
        assert_eq!(step(&list, "/a.nc", 1), Some(PathBuf::from("/b.nc")));
        assert_eq!(step(&list, "/b.nc", 1), Some(PathBuf::from("/a.nc")));
        assert_eq!(step(&list, "/a.nc", -1), Some(PathBuf::from("/b.nc")));
        assert_eq!(step(&[], "", 1), None);
    }

    #[test]
    fn the_list_is_kept_in_the_state_directory() {
        let dir = tempfile::tempdir().expect("dir");
        let state = dir.path().join("state");
        assert!(read(&state).is_empty());
        let list = paths(&["/x/part.nc", "/y/drill.isel"]);
        write(&state, &list).expect("write");
        assert_eq!(read(&state), list);
    }
}
