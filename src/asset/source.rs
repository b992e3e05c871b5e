//! An asset source for the local file system that opens regular files only.
//!
//! Bevy's file reader opens whatever a path names. A FIFO (named pipe) in the asset folder blocks
//! that open until something writes to it, holding one of Bevy's open-file permits for ever; a
//! link to a device (`/dev/zero`, `/dev/random`) reads without end (the hair loaders stop at
//! their byte limits, other loaders may not). A game that loads files players or modders can
//! replace registers this reader as its default source, before `DefaultPlugins`:
//!
//! ```no_run
//! use bevy::asset::io::AssetSourceId;
//! use bevy::prelude::*;
//! use bevy_cartoon_hair::asset::regular_file_source;
//!
//! App::new()
//!     .register_asset_source(AssetSourceId::Default, regular_file_source("assets"))
//!     .add_plugins(DefaultPlugins);
//! ```
//!
//! Every read first asks the file system what the path names (following links) and refuses
//! anything but a regular file with an error naming the path and its kind. The check and the
//! open are two steps: a file swapped for a FIFO between them still blocks.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use bevy::asset::io::file::FileAssetReader;
use bevy::asset::io::{AssetReader, AssetReaderError, AssetSourceBuilder, PathStream, Reader};

/// A [`FileAssetReader`] that refuses devices, FIFOs, sockets and directories. See the module
/// docs.
pub struct RegularFileReader {
    inner: FileAssetReader,
}

impl RegularFileReader {
    /// Reads from `path`, relative to the executable's folder like Bevy's `AssetPlugin::file_path`.
    pub fn new(path: impl AsRef<Path>) -> Self {
        Self {
            inner: FileAssetReader::new(path),
        }
    }

    /// The folder read from.
    pub fn root_path(&self) -> &PathBuf {
        self.inner.root_path()
    }

    /// `Ok` when `path` (relative to the root) names a regular file, following links.
    pub fn check(&self, path: &Path) -> Result<(), AssetReaderError> {
        let full = self.inner.root_path().join(path);
        match std::fs::metadata(&full) {
            Ok(m) if m.is_file() => Ok(()),
            Ok(m) => Err(AssetReaderError::Io(Arc::new(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!(
                    "{} is {}, not a regular file; refused (only regular files are read as assets)",
                    full.display(),
                    kind_of(&m.file_type())
                ),
            )))),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                Err(AssetReaderError::NotFound(full))
            }
            Err(e) => Err(AssetReaderError::Io(Arc::new(e))),
        }
    }
}

fn kind_of(t: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() { "a folder" } else { "not a file" }
}

impl AssetReader for RegularFileReader {
    async fn read<'a>(&'a self, path: &'a Path) -> Result<impl Reader + 'a, AssetReaderError> {
        self.check(path)?;
        self.inner.read(path).await
    }

    async fn read_meta<'a>(&'a self, path: &'a Path) -> Result<impl Reader + 'a, AssetReaderError> {
        let mut meta = path.as_os_str().to_owned();
        meta.push(".meta");
        self.check(Path::new(&meta))?;
        self.inner.read_meta(path).await
    }

    async fn read_directory<'a>(
        &'a self,
        path: &'a Path,
    ) -> Result<Box<PathStream>, AssetReaderError> {
        self.inner.read_directory(path).await
    }

    async fn is_directory<'a>(&'a self, path: &'a Path) -> Result<bool, AssetReaderError> {
        self.inner.is_directory(path).await
    }
}

/// An asset source reading regular files only from `path` (see the module docs). Register it
/// as the default source before `DefaultPlugins`.
pub fn regular_file_source(path: &str) -> AssetSourceBuilder {
    let path = path.to_string();
    AssetSourceBuilder::new(move || Box::new(RegularFileReader::new(&path)))
}
