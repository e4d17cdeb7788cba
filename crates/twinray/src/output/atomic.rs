//! Atomic file output: every encoder writes through [`write_atomically`], and
//! a set of files (both eyes, every view) through [`stage`] and [`commit_all`].
//!
//! The bytes go to a temporary file in the target's directory, which is renamed
//! over the target only once everything was written and flushed. A failure at
//! any point (an encoder error, a full disk, a bad directory) removes the
//! temporary file and leaves whatever was at the target path untouched, so a
//! half-written output file never exists under the requested name.
//!
//! What is at the target decides how it is replaced ([`Target`]):
//! * nothing, or a regular file of ours: the atomic rename; an existing file's
//!   permissions are kept;
//! * a symbolic link: the file it points to is replaced (the link stays);
//! * a FIFO or a character device (`/dev/null`, `/dev/stdout`): written
//!   through, never replaced — the bytes are encoded in memory first;
//! * a read-only file, a directory, a block device, a socket, a dangling link:
//!   refused before anything is written;
//! * a regular file of another user (root writing in a shared directory):
//!   written through, so that it keeps its owner.
//!
//! The temporary files that exist are listed, so that a signal handler can
//! remove them ([`remove_temporary_files`]).

use std::fs::{self, Metadata};
use std::io::{self, BufWriter, Cursor, Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::{Error, Result};

/// Where an encoder writes: a buffered, seekable temporary file.
/// (Seekable because the `exr` writer needs to patch its offset table.)
pub(crate) trait Sink: Write + Seek {}
impl<T: Write + Seek> Sink for T {}

/// Why an encoder stopped: an I/O failure or a refusal of the encoder itself.
#[derive(Debug)]
pub(crate) enum Failure {
    Io(io::Error),
    Encode(String),
}

impl From<io::Error> for Failure {
    fn from(e: io::Error) -> Self {
        Failure::Io(e)
    }
}

impl Failure {
    pub(crate) fn encode(message: impl std::fmt::Display) -> Failure {
        Failure::Encode(message.to_string())
    }

    fn into_error(self, path: &Path) -> Error {
        match self {
            Failure::Io(source) => Error::Io {
                path: path.to_path_buf(),
                source,
            },
            Failure::Encode(message) => Error::Encode {
                path: path.to_path_buf(),
                message,
            },
        }
    }
}

/// How the file at an output path is to be written.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Target {
    /// A new file at `path`, or one replacing a regular file, by rename;
    /// `mode` is the existing file's permission bits to keep.
    Rename { path: PathBuf, mode: Option<u32> },
    /// Written in place (FIFO, character device, another user's file).
    Through { path: PathBuf },
}

fn refuse(path: &Path, why: &str) -> Error {
    Error::Invalid(format!("{}: {why}", path.display()))
}

/// What is at `path` and how to write it; refuses what must not be replaced.
/// Checks that the directory exists.
pub(crate) fn target(path: &Path) -> Result<Target> {
    let io_error = |source: io::Error| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let meta = match fs::symlink_metadata(path) {
        Ok(meta) => meta,
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            let dir = directory_of(path);
            return match fs::metadata(dir) {
                Ok(m) if m.is_dir() => Ok(Target::Rename {
                    path: path.to_path_buf(),
                    mode: None,
                }),
                Ok(_) => Err(refuse(
                    path,
                    &format!("'{}' is not a directory", dir.display()),
                )),
                Err(_) => Err(refuse(path, &format!("no directory '{}'", dir.display()))),
            };
        }
        Err(e) => return Err(io_error(e)),
    };
    if meta.file_type().is_symlink() {
        return match fs::canonicalize(path) {
            Ok(real) => target(&real),
            Err(_) => Err(refuse(path, "a symbolic link to nowhere")),
        };
    }
    if meta.is_dir() {
        return Err(refuse(path, "is a directory"));
    }
    if meta.permissions().readonly() {
        return Err(refuse(path, "is read-only; not replaced"));
    }
    if meta.is_file() {
        return Ok(if owned_by_someone_else(&meta) {
            Target::Through {
                path: path.to_path_buf(),
            }
        } else {
            Target::Rename {
                path: path.to_path_buf(),
                mode: permission_bits(&meta),
            }
        });
    }
    if is_fifo_or_char_device(&meta) {
        return Ok(Target::Through {
            path: path.to_path_buf(),
        });
    }
    Err(refuse(
        path,
        "is neither a file, a FIFO nor a character device; not written",
    ))
}

fn directory_of(path: &Path) -> &Path {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    }
}

#[cfg(unix)]
fn permission_bits(meta: &Metadata) -> Option<u32> {
    use std::os::unix::fs::PermissionsExt;
    Some(meta.permissions().mode() & 0o7777)
}

#[cfg(not(unix))]
fn permission_bits(_: &Metadata) -> Option<u32> {
    None
}

#[cfg(unix)]
fn owned_by_someone_else(meta: &Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    // /proc/self belongs to the process's effective user.
    fs::metadata("/proc/self").is_ok_and(|me| me.uid() != meta.uid())
}

#[cfg(not(unix))]
fn owned_by_someone_else(_: &Metadata) -> bool {
    false
}

#[cfg(unix)]
fn is_fifo_or_char_device(meta: &Metadata) -> bool {
    use std::os::unix::fs::FileTypeExt;
    meta.file_type().is_fifo() || meta.file_type().is_char_device()
}

#[cfg(not(unix))]
fn is_fifo_or_char_device(_: &Metadata) -> bool {
    false
}

/// The temporary files that exist now (for [`remove_temporary_files`]).
static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn temporaries() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    TEMPORARIES
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Removes every temporary output file of this process. For signal handlers
/// (SIGINT, SIGTERM): the process is about to exit in the middle of a write.
pub fn remove_temporary_files() {
    remove_temporaries(|_| true);
}

fn remove_temporaries(which: impl Fn(&Path) -> bool) {
    temporaries().retain(|path| {
        if which(path) {
            let _ = fs::remove_file(path);
        }
        !which(path)
    });
}

/// A temporary file on the list of [`remove_temporary_files`] while it lives.
struct Temporary(tempfile::NamedTempFile);

impl Temporary {
    fn create(dir: &Path, mode: Option<u32>) -> io::Result<Temporary> {
        let mut builder = tempfile::Builder::new();
        builder.prefix(".twinray-").suffix(".tmp");
        // Temporary files are private (0600) by default; an output file is not.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            builder.permissions(fs::Permissions::from_mode(mode.unwrap_or(0o644)));
        }
        #[cfg(not(unix))]
        let _ = mode;
        let file = builder.tempfile_in(dir)?;
        temporaries().push(file.path().to_path_buf());
        Ok(Temporary(file))
    }

    fn forget(&self) {
        temporaries().retain(|p| p != self.0.path());
    }
}

impl Drop for Temporary {
    fn drop(&mut self) {
        self.forget(); // the NamedTempFile then deletes the file, if still there
    }
}

/// An output encoded and waiting for [`Staged::commit`] (or dropped, which
/// removes its temporary file).
pub struct Staged {
    /// The path the user named (for messages).
    shown: PathBuf,
    write: Pending,
}

enum Pending {
    Rename { temp: Temporary, path: PathBuf },
    Through { bytes: Vec<u8>, path: PathBuf },
}

/// Encodes an output for `path` (into a temporary file next to the file to
/// replace, or into memory for a FIFO or device) without touching `path`.
pub(crate) fn stage<F>(path: &Path, encode: F) -> Result<Staged>
where
    F: FnOnce(&mut dyn Sink) -> std::result::Result<(), Failure>,
{
    let io_error = |source: io::Error| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let write = match target(path)? {
        Target::Through { path: real } => {
            let mut bytes = Cursor::new(Vec::new());
            encode(&mut bytes).map_err(|f| f.into_error(path))?;
            Pending::Through {
                bytes: bytes.into_inner(),
                path: real,
            }
        }
        Target::Rename { path: real, mode } => {
            let temp = Temporary::create(directory_of(&real), mode).map_err(io_error)?;
            let mut writer = BufWriter::new(temp.0.as_file());
            encode(&mut writer).map_err(|f| f.into_error(path))?;
            let file = writer.into_inner().map_err(|e| io_error(e.into_error()))?;
            file.sync_all().map_err(io_error)?;
            Pending::Rename { temp, path: real }
        }
    };
    Ok(Staged {
        shown: path.to_path_buf(),
        write,
    })
}

impl Staged {
    /// The path the output was asked for.
    pub fn path(&self) -> &Path {
        &self.shown
    }

    /// Puts the output in place: the rename, or the bytes written through.
    pub fn commit(self) -> Result<()> {
        let shown = self.shown;
        let io_error = |source: io::Error| Error::Io {
            path: shown.clone(),
            source,
        };
        match self.write {
            Pending::Rename { temp, path } => {
                temp.forget();
                let Temporary(file) = &temp;
                fs::rename(file.path(), &path).map_err(io_error)
            }
            Pending::Through { bytes, path } => {
                let mut file = fs::OpenOptions::new()
                    .write(true)
                    .truncate(true)
                    .open(&path)
                    .map_err(io_error)?;
                file.write_all(&bytes).map_err(io_error)?;
                file.flush().map_err(io_error)
            }
        }
    }
}

/// Puts a set of staged outputs in place, all or none as far as the file
/// system allows: every file was already encoded; if a rename fails, the files
/// this call already put in place are removed again. Returns their paths.
pub fn commit_all(staged: Vec<Staged>) -> Result<Vec<PathBuf>> {
    let mut done: Vec<PathBuf> = Vec::with_capacity(staged.len());
    for s in staged {
        let shown = s.path().to_path_buf();
        if let Err(e) = s.commit() {
            for p in &done {
                let _ = fs::remove_file(p);
            }
            return Err(e);
        }
        done.push(shown);
    }
    Ok(done)
}

/// Runs `encode` against a temporary file next to `path` and renames it to
/// `path` only if `encode` succeeded. Errors name `path` (not the temporary).
pub(crate) fn write_atomically<F>(path: &Path, encode: F) -> Result<()>
where
    F: FnOnce(&mut dyn Sink) -> std::result::Result<(), Failure>,
{
    stage(path, encode)?.commit()
}

/// Writes a text file (statistics, reports) atomically, like every image.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    write_atomically(path, |sink| {
        sink.write_all(text.as_bytes())?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn success_writes_the_bytes_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.bin");
        write_atomically(&path, |w| {
            w.write_all(b"hello")?;
            Ok(())
        })
        .unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"hello");
        assert_eq!(entries(dir.path()), vec!["out.bin".to_string()]);
    }

    #[test]
    fn encoder_failure_leaves_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.png");
        let err = write_atomically(&path, |w| {
            w.write_all(&[0u8; 100_000])?; // more than the buffer: reaches the disk
            Err(Failure::encode("refused"))
        })
        .unwrap_err();
        match err {
            Error::Encode { path: p, message } => {
                assert_eq!(p, path);
                assert_eq!(message, "refused");
            }
            other => panic!("unexpected error {other:?}"),
        }
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn encoder_failure_keeps_the_previous_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.png");
        std::fs::write(&path, b"old").unwrap();
        let result = write_atomically(&path, |w| {
            w.write_all(b"new, partial")?;
            Err(Failure::encode("refused"))
        });
        assert!(result.is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(entries(dir.path()), vec!["out.png".to_string()]);
    }

    #[test]
    fn missing_directory_is_an_error_naming_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no_such_dir").join("out.png");
        let err = write_atomically(&path, |_| Ok(())).unwrap_err();
        assert!(
            err.to_string()
                .contains("no_such_dir/out.png: no directory"),
            "{err}"
        );
        assert!(!path.exists());
        assert!(entries(dir.path()).is_empty());
    }

    fn write(path: &Path, bytes: &'static [u8]) -> Result<()> {
        write_atomically(path, |w| {
            w.write_all(bytes)?;
            Ok(())
        })
    }

    #[cfg(unix)]
    #[test]
    fn symlinks_are_followed_and_kept() {
        // The attack: the rename replaced a symbolic link by a file.
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.png");
        let link = dir.path().join("link.png");
        std::fs::write(&real, b"old").unwrap();
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        let dangling = dir.path().join("dangling.png");
        std::os::unix::fs::symlink(dir.path().join("nowhere/x"), &dangling).unwrap();
        assert!(write(&dangling, b"x").is_err());
    }

    #[cfg(unix)]
    #[test]
    fn devices_and_fifos_are_written_through() {
        // The attack: `--stats /dev/null` as root would have replaced /dev/null.
        use std::os::unix::fs::FileTypeExt;
        write(Path::new("/dev/null"), b"stats").unwrap();
        assert!(std::fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device());
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            return; // no mkfifo on this system
        }
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(fifo).unwrap())
        };
        write(&fifo, b"through the pipe").unwrap();
        assert_eq!(reader.join().unwrap(), b"through the pipe");
        assert!(std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo());
        assert_eq!(entries(dir.path()), vec!["pipe".to_string()]);
    }

    #[cfg(unix)]
    #[test]
    fn permissions_are_kept_and_read_only_files_refused() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.png");
        std::fs::write(&path, b"old").unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o640)).unwrap();
        write(&path, b"new").unwrap();
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o640);
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o444)).unwrap();
        let err = write(&path, b"newer").unwrap_err();
        assert!(err.to_string().contains("read-only"), "{err}");
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        assert!(write(dir.path(), b"x").is_err(), "a directory");
    }

    #[test]
    fn a_set_is_committed_together() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.png"), dir.path().join("b.png"));
        let staged_a = stage(&a, |w| Ok(w.write_all(b"a")?)).unwrap();
        // The second fails to encode: nothing of the set appears.
        let failed = stage(&b, |_| Err(Failure::encode("refused")));
        assert!(failed.is_err());
        drop(staged_a);
        assert!(entries(dir.path()).is_empty());
        let set = vec![
            stage(&a, |w| Ok(w.write_all(b"a")?)).unwrap(),
            stage(&b, |w| Ok(w.write_all(b"b")?)).unwrap(),
        ];
        assert_eq!(entries(dir.path()).len(), 2, "two temporaries");
        assert_eq!(commit_all(set).unwrap(), vec![a.clone(), b.clone()]);
        assert_eq!(
            entries(dir.path()),
            vec!["a.png".to_string(), "b.png".to_string()]
        );
    }

    #[test]
    fn temporaries_can_be_removed_from_outside() {
        // What the CLI's SIGINT/SIGTERM handler does mid-write.
        let dir = tempfile::tempdir().unwrap();
        let staged = stage(&dir.path().join("a.png"), |w| Ok(w.write_all(b"a")?)).unwrap();
        assert_eq!(entries(dir.path()).len(), 1);
        // Only this test's: other tests write at the same time.
        remove_temporaries(|p| p.starts_with(dir.path()));
        assert!(entries(dir.path()).is_empty());
        drop(staged);
    }

    #[test]
    fn relative_path_without_directory_uses_the_current_directory() {
        // Only checks that an empty parent is not passed to tempfile (which
        // would fail); writes nothing because the encoder refuses.
        let err = write_atomically(Path::new("twinray-atomic-test.bin"), |_| {
            Err(Failure::encode("nothing"))
        })
        .unwrap_err();
        assert!(matches!(err, Error::Encode { .. }));
        assert!(!Path::new("twinray-atomic-test.bin").exists());
    }
}
