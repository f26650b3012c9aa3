//! A file the user names for output, written so that no data is lost:
//! never over the input or a file the input read (the same file by
//! identity, whatever the spelling, links included), and whole or not at
//! all. The bytes go to a temporary file beside the target, are flushed to
//! the disk, and only then take the target's name, so a full disk, an
//! error or a signal leaves the previous file as it was. On Linux the
//! temporary file has no name until it is complete (`O_TMPFILE`), so even a
//! `kill -9` leaves no fragment behind.

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::shown;

/// The files a command read, to be kept from being written over.
#[derive(Default)]
pub struct ReadFiles {
    files: Vec<(PathBuf, Identity)>,
}

impl ReadFiles {
    /// Notes `path` as read (a file that cannot be looked at is no risk).
    pub fn add(&mut self, path: &Path) {
        if let Some(id) = Identity::of(path) {
            self.files.push((path.to_path_buf(), id));
        }
    }

    /// An error when `target` is one of the files read; `allowed` (the
    /// user's explicit word) lets the input be replaced, still atomically.
    pub fn refuse_overwrite(&self, target: &Path, allowed: bool) -> Result<(), String> {
        let Some(id) = Identity::of(target) else {
            return Ok(());
        };
        match self.files.iter().find(|(_, read)| *read == id) {
            Some((read, _)) if !allowed => Err(format!(
                "--out '{}' is the file '{}' this command read: writing it would destroy the input; \
                 name another file, or add --replace-input to replace it",
                shown(target),
                shown(read)
            )),
            _ => Ok(()),
        }
    }
}

/// What makes two paths one file: device and inode on Unix (links
/// included), the resolved path elsewhere.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Identity(#[cfg(unix)] (u64, u64), #[cfg(not(unix))] PathBuf);

impl Identity {
    fn of(path: &Path) -> Option<Identity> {
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            let m = std::fs::metadata(path).ok()?;
            Some(Identity((m.dev(), m.ino())))
        }
        #[cfg(not(unix))]
        {
            Some(Identity(path.canonicalize().ok()?))
        }
    }
}

/// Writes `bytes` to `target` atomically: afterwards `target` holds either
/// what it held before (on any error, or a signal) or all of `bytes`, and
/// no temporary file is left. A link at `target` keeps pointing where it
/// did; the file it leads to is replaced, its permissions kept.
pub fn write_atomically(target: &Path, bytes: &[u8]) -> Result<(), String> {
    let fail = |e: std::io::Error| format!("cannot write '{}': {e}", shown(target));
    let existing = std::fs::metadata(target).ok();
    if let Some(m) = &existing
        && !m.is_file()
    {
        return Err(format!(
            "cannot write '{}': it is not a regular file (a folder, a device or a pipe)",
            shown(target)
        ));
    }
    // Where the bytes will live: the file a link leads to.
    let target = match existing {
        Some(_) => target.canonicalize().map_err(fail)?,
        None => target.to_path_buf(),
    };
    let folder = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = target
        .file_name()
        .ok_or_else(|| format!("cannot write '{}': it names no file", shown(&target)))?;
    let permissions = existing.map(|m| m.permissions());
    let temporary = folder.join(format!(
        ".{}.{}.part",
        name.to_string_lossy(),
        std::process::id()
    ));
    let fill = |mut file: File| -> std::io::Result<File> {
        if let Some(p) = &permissions {
            file.set_permissions(p.clone())?;
        }
        file.write_all(bytes)?;
        file.sync_all()?;
        Ok(file)
    };
    #[cfg(target_os = "linux")]
    if let Some(file) = unnamed_file(&folder) {
        // Named only once complete, then renamed at once.
        let file = fill(file).map_err(fail)?;
        let _named = NameWatch::new(&temporary);
        if link_unnamed(&file, &temporary).is_ok() {
            return finish(&temporary, &target, &folder).map_err(fail);
        }
    }
    let _named = NameWatch::new(&temporary);
    let file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&temporary)
        .map_err(fail)?;
    let written = fill(file).and_then(|_| finish(&temporary, &target, &folder));
    if written.is_err() {
        let _ = std::fs::remove_file(&temporary);
    }
    written.map_err(fail)
}

/// Gives the complete temporary file the target's name, and makes the
/// rename itself durable.
fn finish(temporary: &Path, target: &Path, folder: &Path) -> std::io::Result<()> {
    if let Err(e) = std::fs::rename(temporary, target) {
        let _ = std::fs::remove_file(temporary);
        return Err(e);
    }
    // The folder's entry: without this a crash may still lose the rename.
    if let Ok(dir) = File::open(folder) {
        let _ = dir.sync_all();
    }
    Ok(())
}

/// A file in `folder` with no name, gone with the process unless linked.
#[cfg(target_os = "linux")]
fn unnamed_file(folder: &Path) -> Option<File> {
    use std::os::unix::fs::OpenOptionsExt;
    OpenOptions::new()
        .write(true)
        .mode(0o666)
        .custom_flags(libc::O_TMPFILE)
        .open(folder)
        .ok()
}

/// Gives the unnamed `file` the name `path`.
#[cfg(target_os = "linux")]
fn link_unnamed(file: &File, path: &Path) -> std::io::Result<()> {
    use std::ffi::CString;
    use std::os::unix::ffi::OsStrExt;
    use std::os::unix::io::AsRawFd;
    let from = CString::new(format!("/proc/self/fd/{}", file.as_raw_fd()))?;
    let to = CString::new(path.as_os_str().as_bytes())?;
    // SAFETY: both are valid NUL-terminated strings that outlive the call.
    let rc = unsafe {
        libc::linkat(
            libc::AT_FDCWD,
            from.as_ptr(),
            libc::AT_FDCWD,
            to.as_ptr(),
            libc::AT_SYMLINK_FOLLOW,
        )
    };
    match rc {
        0 => Ok(()),
        _ => Err(std::io::Error::last_os_error()),
    }
}

/// The temporary file's name, for the signal handler to remove.
#[cfg(unix)]
static PENDING: std::sync::atomic::AtomicPtr<libc::c_char> =
    std::sync::atomic::AtomicPtr::new(std::ptr::null_mut());

/// The signals that end a process by default and can be caught.
#[cfg(unix)]
const ENDING: [libc::c_int; 3] = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP];

/// While a temporary file has a name, the signals that would end the
/// process (on whichever thread) first remove it, then end it as they
/// would have.
struct NameWatch {
    #[cfg(unix)]
    name: std::ffi::CString,
    #[cfg(unix)]
    before: Vec<(libc::c_int, libc::sigaction)>,
}

#[cfg(unix)]
extern "C" fn remove_and_end(signal: libc::c_int) {
    let name = PENDING.swap(std::ptr::null_mut(), std::sync::atomic::Ordering::SeqCst);
    // SAFETY: unlink, signal and raise are async-signal-safe; `name` is the
    // live CString a NameWatch set, cleared before it is freed.
    unsafe {
        if !name.is_null() {
            libc::unlink(name);
        }
        libc::signal(signal, libc::SIG_DFL);
        libc::raise(signal);
    }
}

impl NameWatch {
    #[cfg(unix)]
    fn new(path: &Path) -> NameWatch {
        use std::os::unix::ffi::OsStrExt;
        let name = std::ffi::CString::new(path.as_os_str().as_bytes()).unwrap_or_default();
        PENDING.store(
            name.as_ptr().cast_mut(),
            std::sync::atomic::Ordering::SeqCst,
        );
        let mut before = Vec::new();
        for signal in ENDING {
            // SAFETY: a zeroed sigaction with a handler and an empty mask
            // is a valid argument; the old action is written to `old`.
            unsafe {
                let mut action: libc::sigaction = std::mem::zeroed();
                action.sa_sigaction = remove_and_end as *const () as libc::sighandler_t;
                libc::sigemptyset(&mut action.sa_mask);
                let mut old: libc::sigaction = std::mem::zeroed();
                if libc::sigaction(signal, &action, &mut old) == 0 {
                    before.push((signal, old));
                }
            }
        }
        NameWatch { name, before }
    }

    #[cfg(not(unix))]
    fn new(_: &Path) -> NameWatch {
        NameWatch {}
    }
}

impl Drop for NameWatch {
    fn drop(&mut self) {
        #[cfg(unix)]
        {
            PENDING.store(std::ptr::null_mut(), std::sync::atomic::Ordering::SeqCst);
            for (signal, old) in &self.before {
                // SAFETY: restores the action saved in `new`.
                unsafe {
                    libc::sigaction(*signal, old, std::ptr::null_mut());
                }
            }
            let _ = &self.name;
        }
    }
}
