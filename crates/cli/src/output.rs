//! Writing outputs without losing anyone's data.
//!
//! Every command that writes a folder (`simulate`, `convert`, `reproduce`) or a file (`view`, `check --out`)
//! goes through here:
//!
//! - it refuses an existing file, or a non-empty folder, that the same command did not write, unless `--force`;
//! - a folder it wrote carries a marker file, [`MARKER`], naming the command, so running the same command again
//!   replaces its own previous output (the README's `pmon reproduce` twice in a row still works); a file it
//!   wrote is recognised by a marker inside it (see [`OutputFile`]);
//! - everything is written under a temporary name beside the target (`.NAME.pmon-tmp-PID`) and renamed at the
//!   end, so an interrupted run leaves a visibly temporary folder, never a half recording that looks whole.

use std::fs;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

/// Name of the marker file in every folder pmon writes; its content is `pmon COMMAND`.
pub const MARKER: &str = ".pmon-output";

/// The text pmon puts into every file it writes as a single file, so that it can recognise its own output.
pub const FILE_TAG: &str = "pmon-output";

fn temp_sibling(target: &Path, what: &str) -> Result<PathBuf> {
    let name = target
        .file_name()
        .with_context(|| format!("{}: not a file or folder name", target.display()))?
        .to_string_lossy()
        .into_owned();
    let parent = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    Ok(parent.join(format!(".{name}.pmon-{what}-{}", std::process::id())))
}

/// Refuses folders that hold the current directory (`--out .`, `--out ..`): they cannot be replaced.
fn refuse_cwd(target: &Path) -> Result<()> {
    if let (Ok(t), Ok(cwd)) = (fs::canonicalize(target), std::env::current_dir().and_then(fs::canonicalize)) {
        if cwd.starts_with(&t) {
            bail!("{}: the output folder contains the current directory; choose a new folder", target.display());
        }
    }
    Ok(())
}

/// A folder being written under a temporary name.
pub struct OutputDir {
    target: PathBuf,
    temp: PathBuf,
    command: &'static str,
    committed: bool,
}

impl OutputDir {
    /// Checks that `target` may be written by `pmon COMMAND` and creates the temporary folder.
    ///
    /// # Errors
    /// `target` is a file, or a non-empty folder without this command's marker, and `force` is false; I/O.
    pub fn prepare(target: &Path, command: &'static str, force: bool) -> Result<Self> {
        if let Ok(meta) = fs::symlink_metadata(target) {
            refuse_cwd(target)?;
            if !meta.is_dir() && !force {
                bail!(
                    "{} exists and is not a folder: pmon {command} will not replace it (pass --force to replace it, \
                     or choose another --out)",
                    target.display()
                );
            }
            if meta.is_dir() && !force {
                let marker = fs::read_to_string(target.join(MARKER)).unwrap_or_default();
                let ours = marker.trim() == format!("pmon {command}");
                let empty =
                    fs::read_dir(target).with_context(|| format!("cannot read {}", target.display()))?.next().is_none();
                if !(ours || empty) {
                    bail!(
                        "{} is not empty and was not written by pmon {command} (no {MARKER} marker): nothing written; \
                         pass --force to replace the folder, or choose another --out",
                        target.display()
                    );
                }
            }
        }
        let temp = temp_sibling(target, "tmp")?;
        if temp.exists() {
            fs::remove_dir_all(&temp).with_context(|| format!("cannot remove {}", temp.display()))?;
        }
        fs::create_dir_all(&temp).with_context(|| format!("cannot create {}", temp.display()))?;
        Ok(Self { target: target.to_path_buf(), temp, command, committed: false })
    }

    /// Where to write now (the temporary folder).
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.temp
    }

    /// Writes the marker and moves the temporary folder to the target, replacing a previous output.
    ///
    /// # Errors
    /// I/O.
    pub fn commit(mut self) -> Result<()> {
        fs::write(self.temp.join(MARKER), format!("pmon {}\n", self.command))
            .with_context(|| format!("cannot write the marker in {}", self.temp.display()))?;
        replace_with(&self.target, &self.temp)?;
        self.committed = true;
        Ok(())
    }
}

impl Drop for OutputDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = fs::remove_dir_all(&self.temp);
        }
    }
}

/// Writes `text` to `path` through a temporary file beside it and a rename: a reader never sees half a file.
///
/// # Errors
/// I/O, naming the file.
pub fn write_atomic(path: &Path, text: &str) -> Result<()> {
    let tmp = path.with_extension(format!("tmp-{}", std::process::id()));
    fs::write(&tmp, text).with_context(|| format!("cannot write {}", tmp.display()))?;
    fs::rename(&tmp, path).with_context(|| format!("cannot rename {} to {}", tmp.display(), path.display()))
}

/// Moves `temp` to `target`; an existing `target` is moved aside first and removed after.
fn replace_with(target: &Path, temp: &Path) -> Result<()> {
    let old = if fs::symlink_metadata(target).is_ok() {
        let old = temp_sibling(target, "old")?;
        fs::rename(target, &old).with_context(|| format!("cannot move the old {} aside", target.display()))?;
        Some(old)
    } else {
        if let Some(parent) = target.parent().filter(|p| !p.as_os_str().is_empty()) {
            fs::create_dir_all(parent).with_context(|| format!("cannot create {}", parent.display()))?;
        }
        None
    };
    fs::rename(temp, target).with_context(|| format!("cannot rename {} to {}", temp.display(), target.display()))?;
    if let Some(old) = old {
        let removed = if old.is_dir() { fs::remove_dir_all(&old) } else { fs::remove_file(&old) };
        removed.with_context(|| format!("cannot remove the previous output {}", old.display()))?;
    }
    Ok(())
}

/// A single file being written under a temporary name.
///
/// A file pmon wrote is recognised by [`FILE_TAG`] in its first 64 KiB or last 4 KiB (PNG: a `tEXt` chunk; SVG:
/// a comment; `pmon check` output: its totals line or record); any other existing file is refused unless `--force`.
pub struct OutputFile {
    target: PathBuf,
    temp: PathBuf,
    committed: bool,
}

impl OutputFile {
    /// Checks that `target` may be written.
    ///
    /// # Errors
    /// `target` exists and is not pmon's output, and `force` is false.
    pub fn prepare(target: &Path, command: &str, force: bool) -> Result<Self> {
        if let Ok(meta) = fs::symlink_metadata(target) {
            if meta.is_dir() {
                bail!("{} is a folder: pmon {command} writes a file", target.display());
            }
            if !force && !is_pmon_file(target) {
                bail!(
                    "{} exists and was not written by pmon: nothing written; pass --force to replace it, or \
                     choose another name",
                    target.display()
                );
            }
        }
        let temp = temp_sibling(target, "tmp")?;
        // Keep the extension: the image writers choose the format by it.
        let temp = match target.extension() {
            Some(ext) => temp.with_extension(ext),
            None => temp,
        };
        Ok(Self { target: target.to_path_buf(), temp, committed: false })
    }

    /// Where to write now.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.temp
    }

    /// Moves the written file to the target.
    ///
    /// # Errors
    /// I/O.
    pub fn commit(mut self) -> Result<()> {
        replace_with(&self.target, &self.temp)?;
        self.committed = true;
        Ok(())
    }
}

impl Drop for OutputFile {
    fn drop(&mut self) {
        if !self.committed {
            let _ = fs::remove_file(&self.temp);
        }
    }
}

fn is_pmon_file(path: &Path) -> bool {
    use std::io::{Read, Seek, SeekFrom};
    let has_tag = |bytes: &[u8]| bytes.windows(FILE_TAG.len()).any(|w| w == FILE_TAG.as_bytes());
    let Ok(mut file) = fs::File::open(path) else { return false };
    let mut head = Vec::new();
    if (&mut file).take(65_536).read_to_end(&mut head).is_err() {
        return false;
    }
    if has_tag(&head) {
        return true;
    }
    let mut tail = Vec::new();
    file.seek(SeekFrom::End(-4096)).is_ok() && file.read_to_end(&mut tail).is_ok() && has_tag(&tail)
}

/// Puts [`FILE_TAG`] into an SVG as a comment after the XML declaration (or at the start).
#[must_use]
pub fn tag_svg(text: &str) -> String {
    let comment = format!("<!-- {FILE_TAG}: written by pmon -->\n");
    match text.strip_prefix("<?xml").and_then(|rest| rest.find("?>").map(|i| i + 5 + 2)) {
        Some(end) => format!("{}\n{comment}{}", &text[..end], &text[end..]),
        None => format!("{comment}{text}"),
    }
}

/// Adds a PNG `tEXt` chunk `Software: pmon-output` after the header chunk, so that pmon recognises the image
/// as its own. Returns the bytes unchanged when they are not a PNG.
#[must_use]
pub fn tag_png(bytes: &[u8]) -> Vec<u8> {
    const SIG: &[u8] = b"\x89PNG\r\n\x1a\n";
    // Signature (8) + IHDR chunk (4 length + 4 type + 13 data + 4 CRC).
    let ihdr_end = 8 + 25;
    if bytes.len() < ihdr_end || !bytes.starts_with(SIG) || bytes.get(12..16) != Some(b"IHDR".as_slice()) {
        return bytes.to_vec();
    }
    let mut data = b"Software\0".to_vec();
    data.extend_from_slice(FILE_TAG.as_bytes());
    let mut chunk = Vec::with_capacity(12 + data.len());
    chunk.extend_from_slice(&(data.len() as u32).to_be_bytes());
    let mut typed = b"tEXt".to_vec();
    typed.extend_from_slice(&data);
    chunk.extend_from_slice(&typed);
    chunk.extend_from_slice(&crc32(&typed).to_be_bytes());
    let mut out = Vec::with_capacity(bytes.len() + chunk.len());
    out.extend_from_slice(&bytes[..ihdr_end]);
    out.extend_from_slice(&chunk);
    out.extend_from_slice(&bytes[ihdr_end..]);
    out
}

/// CRC-32 (IEEE, as PNG uses), bitwise: a few dozen bytes per image.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xFFFF_FFFFu32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_matches_the_png_specification_example() {
        // CRC of "IEND" with no data, as in every PNG file.
        assert_eq!(crc32(b"IEND"), 0xAE42_6082);
    }

    #[test]
    fn foreign_folder_is_refused_and_own_output_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out");
        fs::create_dir(&target).unwrap();
        fs::write(target.join("thesis.tex"), "precious").unwrap();
        let err = OutputDir::prepare(&target, "simulate", false).err().unwrap().to_string();
        assert!(err.contains("not empty") && err.contains("--force"), "{err}");
        assert_eq!(fs::read_to_string(target.join("thesis.tex")).unwrap(), "precious");
        // Forced: replaced as a whole.
        let out = OutputDir::prepare(&target, "simulate", true).unwrap();
        fs::write(out.path().join("a"), "1").unwrap();
        out.commit().unwrap();
        assert!(!target.join("thesis.tex").exists() && target.join("a").exists());
        // Now it is ours: a second run replaces it without --force; another command does not.
        let out = OutputDir::prepare(&target, "simulate", false).unwrap();
        fs::write(out.path().join("b"), "2").unwrap();
        out.commit().unwrap();
        assert!(!target.join("a").exists() && target.join("b").exists());
        assert!(OutputDir::prepare(&target, "convert", false).is_err());
        // Nothing temporary is left beside it.
        let names: Vec<_> = fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names.len(), 1, "{names:?}");
    }

    #[test]
    fn an_abandoned_write_leaves_no_folder_that_looks_whole() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out");
        {
            let out = OutputDir::prepare(&target, "simulate", false).unwrap();
            fs::write(out.path().join("recording.json"), "{}").unwrap();
            // dropped without commit: an error happened
        }
        assert!(!target.exists());
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn foreign_file_is_refused_own_file_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("frame.png");
        fs::write(&target, "holiday photo").unwrap();
        assert!(OutputFile::prepare(&target, "view", false).is_err());
        fs::write(&target, format!("xx {FILE_TAG} xx")).unwrap();
        let out = OutputFile::prepare(&target, "view", false).unwrap();
        fs::write(out.path(), "new").unwrap();
        out.commit().unwrap();
        assert_eq!(fs::read_to_string(&target).unwrap(), "new");
    }
}
