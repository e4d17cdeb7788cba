//! The files a load reads: the scene file the user named, and the files it
//! names in turn (glTF buffers and images, OBJ material libraries and their
//! texture maps).
//!
//! * A file a scene names is a path relative to the scene's folder, after a
//!   glTF URI's `%xx` escapes are decoded and backslashes are taken for
//!   slashes. It is read only if it lies in the scene's folder or below, or
//!   in a folder the user allowed (`LoadOptions::allow_dirs`, the command
//!   line's `--allow-dir`): first by its name (`..` and absolute paths
//!   resolved without touching the disk), then where symbolic links lead.
//! * Every file read is a regular file, checked on the opened handle (a
//!   FIFO is opened without blocking): no device (`/dev/zero`), FIFO,
//!   socket or directory. Each read stops at a size cap.
//! * What a refusal says never describes the file refused: not its size,
//!   not whether it exists.
//!
//! The files read are recorded ([`SceneFiles::inputs`]), so that a job can
//! refuse an output that would replace one of them.

use std::cell::RefCell;
use std::io::Read;
use std::path::{Component, Path, PathBuf};

use crate::memory::{human_bytes, Budget};
use crate::{Error, Result};

/// Largest file a load reads (a scene, a buffer, an image), in bytes.
pub const MAX_FILE_BYTES: u64 = 4 << 30;

/// Largest text file a job reads beside its scene (a job file, a camera
/// path), in bytes.
pub const MAX_TEXT_BYTES: u64 = 64 << 20;

/// Why a file was not read.
#[derive(Debug)]
enum Unread {
    Io(std::io::Error),
    Directory,
    NotRegular,
    TooLarge { cap: u64 },
    Refused(Error),
}

impl Unread {
    fn describe(&self) -> String {
        match self {
            Unread::Io(e) => e.to_string(),
            Unread::Directory => "is a directory, not a file".into(),
            Unread::NotRegular => {
                "is not a regular file (a device, FIFO or socket): not read".into()
            }
            Unread::TooLarge { cap } => {
                format!(
                    "is larger than {}, the most a file may be",
                    human_bytes(*cap)
                )
            }
            Unread::Refused(e) => e.to_string(),
        }
    }
}

/// Opens `path` for reading if it is a regular file: checked on the opened
/// handle, so that nothing can be swapped in between; a FIFO is opened
/// without blocking (else opening it would wait for a writer forever).
fn open_regular(path: &Path) -> std::result::Result<(std::fs::File, u64), Unread> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(Unread::Io)?;
    let meta = file.metadata().map_err(Unread::Io)?;
    if meta.is_dir() {
        return Err(Unread::Directory);
    }
    if !meta.is_file() {
        return Err(Unread::NotRegular);
    }
    Ok((file, meta.len()))
}

/// Reads a regular file of at most `cap` bytes; `reserve` is asked first
/// with its size (to count it against a budget).
fn read_regular(
    path: &Path,
    cap: u64,
    reserve: &dyn Fn(u64) -> Result<()>,
) -> std::result::Result<Vec<u8>, Unread> {
    let (file, len) = open_regular(path)?;
    if len > cap {
        return Err(Unread::TooLarge { cap });
    }
    reserve(len).map_err(Unread::Refused)?;
    let mut bytes = Vec::new();
    bytes.try_reserve_exact(len as usize).map_err(|_| {
        Unread::Refused(Error::Invalid(format!(
            "cannot allocate {} of memory to read it",
            human_bytes(len)
        )))
    })?;
    // The size can change after the check: the read stops past the cap.
    file.take(cap + 1)
        .read_to_end(&mut bytes)
        .map_err(Unread::Io)?;
    if bytes.len() as u64 > cap {
        return Err(Unread::TooLarge { cap });
    }
    Ok(bytes)
}

/// Reads a file the user named (a scene, `--env`, a camera path, a job
/// file): a regular file of at most `cap` bytes.
pub fn read_user_file(path: &Path, cap: u64) -> Result<Vec<u8>> {
    read_regular(path, cap, &|_| Ok(())).map_err(|e| user_file_error(path, e))
}

/// [`read_user_file`] of a text file, at most [`MAX_TEXT_BYTES`]; `what`
/// names it in errors (`--job`, `--path`).
pub fn read_user_text(path: &Path, what: &str) -> Result<String> {
    let bytes =
        read_user_file(path, MAX_TEXT_BYTES).map_err(|e| Error::Invalid(format!("{what} {e}")))?;
    String::from_utf8(bytes).map_err(|e| {
        Error::Invalid(format!(
            "{what} {}: not a text file (invalid UTF-8 at byte {})",
            path.display(),
            e.utf8_error().valid_up_to()
        ))
    })
}

fn user_file_error(path: &Path, e: Unread) -> Error {
    match e {
        Unread::Io(source) => Error::Io {
            path: path.to_path_buf(),
            source,
        },
        other => Error::Invalid(format!("{}: {}", path.display(), other.describe())),
    }
}

/// `path` with `.` and `..` resolved by name, without touching the disk
/// (`..` above the root stays at the root).
fn lexical(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            other => out.push(other.as_os_str()),
        }
    }
    out
}

/// `path` made absolute from the working directory, by name.
fn absolute(path: &Path) -> PathBuf {
    let path = if path.as_os_str().is_empty() {
        Path::new(".")
    } else {
        path
    };
    lexical(&std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf()))
}

/// A folder a scene may read from: by name, and where its links lead.
#[derive(Debug)]
struct Root {
    lexical: PathBuf,
    canonical: Option<PathBuf>,
}

impl Root {
    fn new(dir: &Path) -> Root {
        Root {
            lexical: absolute(dir),
            canonical: std::fs::canonicalize(dir).ok(),
        }
    }
}

/// The files one load reads: where a scene's references may lead, and
/// which files were read.
#[derive(Debug)]
pub struct SceneFiles {
    scene: PathBuf,
    roots: Vec<Root>,
    read: RefCell<Vec<PathBuf>>,
}

impl SceneFiles {
    /// The files of a load of `scene`, which may read its own folder and
    /// `allowed` (each with what is below it).
    pub fn new(scene: &Path, allowed: &[PathBuf]) -> SceneFiles {
        let folder = scene.parent().unwrap_or(Path::new(""));
        let roots = std::iter::once(folder)
            .chain(allowed.iter().map(PathBuf::as_path))
            .map(Root::new)
            .collect();
        SceneFiles {
            scene: scene.to_path_buf(),
            roots,
            read: RefCell::new(Vec::new()),
        }
    }

    /// The scene's folder, as messages name it.
    fn folder(&self) -> String {
        self.roots[0].lexical.display().to_string()
    }

    /// Reads the scene file itself (the user named it: it is not confined),
    /// counting its size against `budget`.
    pub fn read_scene(&self, budget: &Budget) -> Result<Vec<u8>> {
        let path = &self.scene;
        let take = |len: u64| budget.take(len, &|| format!("reading {}", path.display()));
        let bytes =
            read_regular(path, MAX_FILE_BYTES, &take).map_err(|e| user_file_error(path, e))?;
        self.record(path);
        Ok(bytes)
    }

    /// Where `name` (as the scene gives it, relative to its folder) leads,
    /// if the scene may read it; else why not, in words that describe
    /// nothing about the file.
    pub fn resolve(&self, name: &str) -> std::result::Result<PathBuf, String> {
        let shown = || excerpt_name(name);
        let slashed = name.replace('\\', "/");
        let by_name = lexical(&self.roots[0].lexical.join(&slashed));
        let allow = "--allow-dir DIR lets a scene read another folder";
        if !self.roots.iter().any(|r| by_name.starts_with(&r.lexical)) {
            return Err(format!(
                "'{}' is outside the scene's folder {}: not read ({allow})",
                shown(),
                self.folder()
            ));
        }
        let real = std::fs::canonicalize(&by_name).map_err(|e| format!("'{}': {e}", shown()))?;
        let inside = self
            .roots
            .iter()
            .filter_map(|r| r.canonical.as_ref())
            .any(|root| real.starts_with(root));
        if !inside {
            return Err(format!(
                "'{}' leads outside the scene's folder {} through a symbolic link: not read ({allow})",
                shown(),
                self.folder()
            ));
        }
        Ok(real)
    }

    /// Reads the file `name` leads to ([`SceneFiles::resolve`]), at most
    /// [`MAX_FILE_BYTES`], counting its size against `budget`; the error
    /// says why not, naming `name` (a caller puts the scene and what named
    /// it before).
    pub fn read_named(&self, name: &str, budget: &Budget) -> std::result::Result<Vec<u8>, String> {
        let path = self.resolve(name)?;
        let take = |len: u64| budget.take(len, &|| format!("reading '{}'", excerpt_name(name)));
        let bytes = read_regular(&path, MAX_FILE_BYTES, &take).map_err(|e| match e {
            Unread::Refused(e) => e.to_string(),
            other => format!("'{}' {}", excerpt_name(name), other.describe()),
        })?;
        self.record(&path);
        Ok(bytes)
    }

    fn record(&self, path: &Path) {
        let path = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        let mut read = self.read.borrow_mut();
        if !read.contains(&path) {
            read.push(path);
        }
    }

    /// The files read so far, each once (canonical paths).
    pub fn inputs(&self) -> Vec<PathBuf> {
        self.read.borrow().clone()
    }
}

/// A name from a file as messages quote it: at most 200 characters, with
/// control characters escaped.
fn excerpt_name(name: &str) -> String {
    super::excerpt(name, 200)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn budget() -> Budget {
        Budget::new(None)
    }

    /// A scene folder `dir/scene` with `a.bin`, a sub-folder and a secret
    /// beside it (`dir/secret/x.bin`).
    fn tree() -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("scene");
        std::fs::create_dir_all(scene.join("sub")).unwrap();
        std::fs::create_dir_all(dir.path().join("secret")).unwrap();
        std::fs::write(scene.join("a.bin"), b"inside").unwrap();
        std::fs::write(scene.join("sub/b.bin"), b"below").unwrap();
        std::fs::write(dir.path().join("secret/x.bin"), b"secret").unwrap();
        let file = scene.join("s.gltf");
        std::fs::write(&file, b"{}").unwrap();
        (dir, file)
    }

    #[test]
    fn the_scenes_folder_and_below_are_read_and_recorded() {
        let (_dir, file) = tree();
        let files = SceneFiles::new(&file, &[]);
        assert_eq!(files.read_named("a.bin", &budget()).unwrap(), b"inside");
        assert_eq!(files.read_named("sub/b.bin", &budget()).unwrap(), b"below");
        assert_eq!(files.read_named("sub\\b.bin", &budget()).unwrap(), b"below");
        assert_eq!(
            files.read_named("sub/../a.bin", &budget()).unwrap(),
            b"inside"
        );
        let inputs = files.inputs();
        assert_eq!(inputs.len(), 2, "{inputs:?}");
        assert!(inputs[0].is_absolute() && inputs[0].ends_with("scene/a.bin"));
    }

    #[test]
    fn names_outside_the_folder_are_refused_without_a_word_about_the_file() {
        let (dir, file) = tree();
        let files = SceneFiles::new(&file, &[]);
        let secret = dir.path().join("secret/x.bin");
        for name in [
            "../secret/x.bin".to_string(),
            "..\\secret\\x.bin".to_string(),
            "sub/../../secret/x.bin".to_string(),
            secret.display().to_string(),
            "/etc/passwd".to_string(),
            "../secret/missing.bin".to_string(),
        ] {
            let e = files.read_named(&name, &budget()).unwrap_err();
            assert!(e.contains("is outside the scene's folder"), "{name}: {e}");
            assert!(!e.contains("bytes") && !e.contains("No such"), "{e}");
        }
        assert!(files.inputs().is_empty());
        // Allowed: the folder given, and below it.
        let allowed = SceneFiles::new(&file, &[dir.path().join("secret")]);
        assert_eq!(
            allowed.read_named("../secret/x.bin", &budget()).unwrap(),
            b"secret"
        );
    }

    #[cfg(unix)]
    #[test]
    fn links_are_followed_and_confined_where_they_lead() {
        let (dir, file) = tree();
        let scene = file.parent().unwrap();
        std::os::unix::fs::symlink(dir.path().join("secret/x.bin"), scene.join("out.bin")).unwrap();
        std::os::unix::fs::symlink(scene.join("a.bin"), scene.join("in.bin")).unwrap();
        let files = SceneFiles::new(&file, &[]);
        let e = files.read_named("out.bin", &budget()).unwrap_err();
        assert!(e.contains("through a symbolic link"), "{e}");
        assert_eq!(files.read_named("in.bin", &budget()).unwrap(), b"inside");
        // A scene reached through a linked folder reads its own files.
        let link = dir.path().join("linked");
        std::os::unix::fs::symlink(scene, &link).unwrap();
        let files = SceneFiles::new(&link.join("s.gltf"), &[]);
        assert_eq!(files.read_named("a.bin", &budget()).unwrap(), b"inside");
    }

    #[cfg(unix)]
    #[test]
    fn only_regular_files_are_read() {
        let (dir, file) = tree();
        let scene = file.parent().unwrap();
        std::os::unix::fs::symlink("/dev/zero", scene.join("zero.bin")).unwrap();
        let fifo = scene.join("fifo.bin");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path; mkfifo only creates a file.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let files = SceneFiles::new(&file, &[Path::new("/dev").to_path_buf()]);
        for (name, says) in [
            ("zero.bin", "not a regular file"),
            ("fifo.bin", "not a regular file"),
            ("sub", "is a directory"),
            ("/dev/zero", "not a regular file"),
        ] {
            let e = files.read_named(name, &budget()).unwrap_err();
            assert!(e.contains(says), "{name}: {e}");
        }
        for path in [Path::new("/dev/zero"), fifo.as_path(), dir.path()] {
            let e = read_user_file(path, MAX_FILE_BYTES)
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("not a regular file") || e.contains("directory"),
                "{e}"
            );
        }
    }

    #[test]
    fn reads_stop_at_the_cap_and_count_against_the_budget() {
        let (_dir, file) = tree();
        let a = file.parent().unwrap().join("a.bin");
        let e = read_user_file(&a, 3).unwrap_err().to_string();
        assert!(e.contains("is larger than 3 bytes"), "{e}");
        let small = Budget::new(Some(4));
        let files = SceneFiles::new(&file, &[]);
        let e = files.read_named("a.bin", &small).unwrap_err();
        assert!(e.contains("reading 'a.bin': needs about 6 bytes"), "{e}");
        let fits = Budget::new(Some(6));
        files.read_named("a.bin", &fits).unwrap();
        assert_eq!(fits.taken(), 6);
    }
}
