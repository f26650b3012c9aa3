//! External glTF buffers read from the `.gltf`'s own folder, and nowhere
//! else: the library has already reduced each URI to plain names below the
//! folder; this refuses symbolic links that lead out of it and anything
//! that is not a regular file (a device such as `/dev/zero` never ends), and
//! reads no more than the buffer's declared length.

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use fast_reject::mesh::io::{ResourceError, ResourcePath, ResourceResolver};

/// Resolves resources inside one folder.
pub struct FolderResolver {
    /// The folder, with every symbolic link resolved.
    folder: PathBuf,
    /// The files read, so that an output is never written over one.
    read: Mutex<Vec<PathBuf>>,
}

impl FolderResolver {
    /// Resources of the model file at `model`: those in its folder.
    pub fn beside(model: &Path) -> std::io::Result<FolderResolver> {
        let model = model.canonicalize()?;
        let folder = model.parent().map(Path::to_path_buf).unwrap_or_default();
        Ok(FolderResolver {
            folder,
            read: Mutex::default(),
        })
    }

    /// The files resolved so far.
    pub fn read(&self) -> Vec<PathBuf> {
        self.read.lock().map(|r| r.clone()).unwrap_or_default()
    }
}

impl ResourceResolver for FolderResolver {
    fn resolve(&self, path: &ResourcePath, max_len: usize) -> Result<Vec<u8>, ResourceError> {
        let mut file_path = self.folder.clone();
        file_path.extend(path.components());
        let real = match file_path.canonicalize() {
            Ok(real) => real,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(ResourceError::Missing);
            }
            Err(e) => return Err(ResourceError::Refused(format!("cannot open it: {e}"))),
        };
        if !real.starts_with(&self.folder) {
            return Err(ResourceError::Refused(format!(
                "it is a link to '{}', outside the model's folder '{}'",
                real.display(),
                self.folder.display()
            )));
        }
        let refused = |e: std::io::Error| ResourceError::Refused(format!("cannot read it: {e}"));
        // Checked before it is opened: opening a named pipe for reading
        // blocks until a writer comes, which may be never.
        if !std::fs::metadata(&real).map_err(refused)?.is_file() {
            return Err(not_a_file());
        }
        let file = open_without_blocking(&real).map_err(refused)?;
        if let Ok(mut read) = self.read.lock() {
            read.push(real.clone());
        }
        // Checked on the open file, so that what is read is what was checked.
        if !file.metadata().map_err(refused)?.is_file() {
            return Err(not_a_file());
        }
        let mut bytes = Vec::new();
        file.take(max_len as u64)
            .read_to_end(&mut bytes)
            .map_err(refused)?;
        Ok(bytes)
    }
}

fn not_a_file() -> ResourceError {
    ResourceError::Refused("it is not a regular file (a folder, a device or a pipe)".into())
}

/// Opens `path` for reading; on Unix without waiting for a writer, should
/// it have become a named pipe since it was checked.
fn open_without_blocking(path: &Path) -> std::io::Result<File> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    options.open(path)
}
