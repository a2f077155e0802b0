//! Output files that never leave a half-written file or replace an input: atomic writes, the outputs of one
//! command staged and renamed together ([`Staged`]), and the inputs this process read ([`protect_input`]).

use crate::error::{Error, Result};
use std::io::Write;
use std::path::Path;

/// The files this process has read as input ([`protect_input`]), by canonical path: no output replaces them.
static INPUTS: std::sync::Mutex<Vec<std::path::PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Records `path` as an input of this run: [`write_atomic`] then refuses to replace it, whatever output path names it
/// (`-o`, `--png`, a report folder holding it). The loaders call this for every file they read (dumps, file-set
/// images, sidecars, layout files, merged reports). A path that does not exist is ignored.
pub fn protect_input(path: &Path) {
    if let Ok(p) = std::fs::canonicalize(path) {
        let mut inputs = INPUTS.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if !inputs.contains(&p) {
            inputs.push(p);
        }
    }
}

/// The files recorded by [`protect_input`] in this process (canonical paths, in the order first read). The registry
/// is process-wide on purpose: no output of any command or library call may replace a file anything read.
#[must_use]
pub fn protected_inputs() -> Vec<std::path::PathBuf> {
    INPUTS.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clone()
}

/// Forgets every recorded input: for a long-running library user (a server, a batch over many captures) whose
/// outputs may replace files that earlier jobs read.
pub fn clear_protected_inputs() {
    INPUTS.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clear();
}

/// Refuses `path` as an output when it is a file this run read as input ([`protect_input`]); for callers that
/// write several files and must refuse before the first (a report folder).
pub fn check_not_input(path: &Path) -> Result<()> {
    let is_input = std::fs::canonicalize(path)
        .is_ok_and(|p| INPUTS.lock().unwrap_or_else(std::sync::PoisonError::into_inner).contains(&p));
    if is_input {
        return Err(Error::WouldOverwriteInput { path: path.into() });
    }
    Ok(())
}

/// Writes a file atomically: the bytes go to a temporary file in the same directory, which is then renamed over
/// `path`. A failure leaves whatever was at `path` untouched, and so does a kill at any point (the temporary file
/// is left at worst, under a `.gbuf-tmp-` name). A file this run read as input is never replaced
/// ([`protect_input`]).
pub fn write_atomic(path: &Path, write: impl FnOnce(&mut std::fs::File) -> std::io::Result<()>) -> Result<()> {
    let mut staged = Staged::default();
    staged.stage(path, write)?;
    staged.commit()
}

/// Several outputs of one command, written all or nothing: each is written to a temporary file beside its
/// destination ([`Staged::stage`]), and [`Staged::commit`] renames them all into place once every one was
/// written. Dropped without a commit (a later step failed), it removes its temporary files and leaves every
/// destination as it was.
#[derive(Default)]
pub struct Staged {
    files: Vec<(tempfile::NamedTempFile, std::path::PathBuf)>,
}

impl Staged {
    /// Writes `path`'s future contents to a temporary file beside it (refused when `path` is an input of this run).
    pub fn stage(&mut self, path: &Path, write: impl FnOnce(&mut std::fs::File) -> std::io::Result<()>) -> Result<()> {
        check_not_input(path)?;
        if path.is_dir() {
            return Err(Error::io(path, std::io::Error::other("is a directory, not a file")));
        }
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let mut tmp = tempfile::Builder::new().prefix(".gbuf-tmp-").tempfile_in(dir).map_err(|e| Error::io(path, e))?;
        // tempfile creates files readable by the owner only; an output should get the usual permissions (those of
        // the file it replaces, else rw-r--r-- before the umask's say, as a plain File::create would give).
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(path).map(|m| m.permissions().mode()).unwrap_or(0o644);
            std::fs::set_permissions(tmp.path(), std::fs::Permissions::from_mode(mode & 0o7777))
                .map_err(|e| Error::io(path, e))?;
        }
        write(tmp.as_file_mut()).map_err(|e| Error::io(path, e))?;
        tmp.as_file_mut().flush().map_err(|e| Error::io(path, e))?;
        self.files.push((tmp, path.to_path_buf()));
        Ok(())
    }

    /// [`Staged::stage`] of `bytes`.
    pub fn stage_bytes(&mut self, path: &Path, bytes: &[u8]) -> Result<()> {
        self.stage(path, |f| f.write_all(bytes))
    }

    /// Renames every staged file into place, in the order staged. Should a rename fail, the files this commit
    /// created are removed again (a file it replaced stays replaced: the rename is the only step that touches it).
    pub fn commit(self) -> Result<()> {
        let mut created = Vec::new();
        for (tmp, path) in self.files {
            let existed = path.exists();
            if let Err(e) = tmp.persist(&path) {
                for p in created {
                    let _ = std::fs::remove_file(p);
                }
                return Err(Error::io(&path, e.error));
            }
            if !existed {
                created.push(path);
            }
        }
        Ok(())
    }
}

/// Writes `bytes` to `path` atomically (see [`write_atomic`]).
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |f| f.write_all(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.bin");
        write_bytes_atomic(&p, b"one").unwrap();
        write_bytes_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, 0o644, "outputs must not be owner-only");
        }
    }

    #[test]
    fn failed_atomic_write_keeps_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.bin");
        write_bytes_atomic(&p, b"keep").unwrap();
        let r = write_atomic(&p, |_| Err(std::io::Error::other("boom")));
        assert!(r.is_err());
        assert_eq!(std::fs::read(&p).unwrap(), b"keep");
    }
}
