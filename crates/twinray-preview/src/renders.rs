//! The full-size renders' files, kept for download under random ids: the
//! newest [`KEPT_RENDERS`] only (an older one's folder is deleted when a
//! newer one is kept), and every one removed when the server stops.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Full-size renders kept for download, all pages together.
pub const KEPT_RENDERS: usize = 4;

struct Kept {
    id: String,
    dir: PathBuf,
    files: Vec<PathBuf>,
}

/// The renders kept, oldest first.
#[derive(Default)]
pub struct Renders {
    kept: Mutex<VecDeque<Kept>>,
}

impl Renders {
    fn lock(&self) -> std::sync::MutexGuard<'_, VecDeque<Kept>> {
        self.kept.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Keeps the `files` of render `id`, written in `dir` (its own folder);
    /// the oldest renders beyond [`KEPT_RENDERS`] are deleted.
    pub fn keep(&self, id: String, dir: PathBuf, files: Vec<PathBuf>) {
        let dropped: Vec<Kept> = {
            let mut kept = self.lock();
            kept.push_back(Kept { id, dir, files });
            let excess = kept.len().saturating_sub(KEPT_RENDERS);
            kept.drain(..excess).collect()
        };
        for render in dropped {
            remove(&render.dir);
        }
    }

    /// The file `name` of render `id`, if it is kept.
    pub fn file(&self, id: &str, name: &str) -> Option<PathBuf> {
        self.lock()
            .iter()
            .find(|k| k.id == id)
            .and_then(|k| k.files.iter().find(|p| file_name_of(p) == name).cloned())
    }

    /// The ids of the renders kept, oldest first.
    pub fn ids(&self) -> Vec<String> {
        self.lock().iter().map(|k| k.id.clone()).collect()
    }

    /// Deletes every render's folder.
    pub fn remove_all(&self) {
        let all: Vec<Kept> = self.lock().drain(..).collect();
        for render in all {
            remove(&render.dir);
        }
    }
}

/// Deletes a render's folder (a failure leaves it to the temporary
/// folder's own removal at exit).
pub fn remove(dir: &Path) {
    let _ = std::fs::remove_dir_all(dir);
}

/// A file's name as text.
pub fn file_name_of(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_newest_renders_are_kept_and_older_ones_deleted() {
        let root = tempfile::tempdir().unwrap();
        let renders = Renders::default();
        let mut dirs = Vec::new();
        for i in 0..KEPT_RENDERS + 2 {
            let dir = root.path().join(format!("render-{i}"));
            std::fs::create_dir(&dir).unwrap();
            let file = dir.join("a.png");
            std::fs::write(&file, b"png").unwrap();
            renders.keep(format!("id{i}"), dir.clone(), vec![file]);
            dirs.push(dir);
        }
        assert_eq!(renders.ids(), ["id2", "id3", "id4", "id5"]);
        assert!(!dirs[0].exists() && !dirs[1].exists());
        assert!(dirs[2..].iter().all(|d| d.exists()));
        assert_eq!(renders.file("id0", "a.png"), None);
        assert_eq!(renders.file("id5", "a.png"), Some(dirs[5].join("a.png")));
        assert_eq!(renders.file("id5", "../a.png"), None);
        renders.remove_all();
        assert!(dirs.iter().all(|d| !d.exists()));
        assert!(renders.ids().is_empty());
    }
}
