//! Atomic file output: every encoder writes through [`write_atomically`].
//!
//! The bytes go to a temporary file in the target's directory, which is renamed
//! over the target only once everything was written and flushed. A failure at
//! any point (an encoder error, a full disk, a bad directory) removes the
//! temporary file and leaves whatever was at the target path untouched, so a
//! half-written output file never exists under the requested name.

use std::io::{self, BufWriter, Seek, Write};
use std::path::Path;

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

/// Runs `encode` against a temporary file next to `path` and renames it to
/// `path` only if `encode` succeeded. Errors name `path` (not the temporary).
pub(crate) fn write_atomically<F>(path: &Path, encode: F) -> Result<()>
where
    F: FnOnce(&mut dyn Sink) -> std::result::Result<(), Failure>,
{
    let io_error = |source: io::Error| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let dir = match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    };
    // Temporary files are private (0600) by default; an output file is not.
    let mut builder = tempfile::Builder::new();
    builder.prefix(".twinray-").suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    let temp = builder.tempfile_in(dir).map_err(io_error)?;
    let mut writer = BufWriter::new(temp);
    encode(&mut writer).map_err(|f| f.into_error(path))?;
    // On any error below, the NamedTempFile is dropped, which deletes it.
    let temp = writer.into_inner().map_err(|e| io_error(e.into_error()))?;
    temp.as_file().sync_all().map_err(io_error)?;
    temp.persist(path).map_err(|e| io_error(e.error))?;
    Ok(())
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
    fn missing_directory_is_an_io_error_naming_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no_such_dir").join("out.png");
        let err = write_atomically(&path, |_| Ok(())).unwrap_err();
        match &err {
            Error::Io { path: p, .. } => assert_eq!(p, &path),
            other => panic!("unexpected error {other:?}"),
        }
        assert!(err.to_string().contains("no_such_dir"));
        assert!(!path.exists());
        assert!(entries(dir.path()).is_empty());
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
