//! Bounded input: every file mbs reads is refused, unread, when it is longer
//! than the largest valid one of its kind (a 3 GiB "checkpoint" is never
//! read into memory), and files of lines are read a line at a time with a
//! longest line.

use std::fmt;
use std::io::{BufRead, Read};
use std::path::Path;

/// The largest file of a kind: its length in bytes and why no valid file
/// is longer (said in the refusal).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bound<'a> {
    /// Bytes.
    pub bytes: u64,
    /// What the file is and why it cannot be longer, e.g. "the largest
    /// configuration: …".
    pub reason: &'a str,
}

/// `n` bytes in the largest binary unit it reaches (`64 MiB`, `1.5 KiB`).
pub struct Size(pub u64);

impl fmt::Display for Size {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.0 as f64;
        match self.0 {
            0..1024 => write!(f, "{} bytes", self.0),
            1024..0x10_0000 => write!(f, "{} KiB", round(n / 1024.0)),
            0x10_0000..0x4000_0000 => write!(f, "{} MiB", round(n / 1048576.0)),
            _ => write!(f, "{} GiB", round(n / 1073741824.0)),
        }
    }
}

/// One decimal, none when whole.
fn round(x: f64) -> f64 {
    (x * 10.0).round() / 10.0
}

/// The refusal of a file of `size` (e.g. "3 GiB") beyond `bound`.
fn too_large(size: impl fmt::Display, bound: Bound<'_>) -> std::io::Error {
    std::io::Error::new(
        std::io::ErrorKind::InvalidData,
        format!(
            "{size}, longer than {} ({}): refused unread",
            bound.reason,
            Size(bound.bytes)
        ),
    )
}

/// The bytes of `path`, refused unread (an `InvalidData` error) if the file
/// is longer than `bound`; a file that grows while being read (or a device
/// without a length) is read only up to the bound.
pub fn read_bounded(path: &Path, bound: Bound<'_>) -> std::io::Result<Vec<u8>> {
    read_file_bounded(std::fs::File::open(path)?, bound)
}

/// Opens a file of mbs's own in an output directory for reading, refused
/// (an `InvalidData` error) unless it is a regular file: a FIFO or device
/// planted there would block the open or the read forever. Opened without
/// blocking (unix), then checked on the open file itself.
pub fn open_own_file(path: &Path) -> std::io::Result<std::fs::File> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path)?;
    regular(&file)?;
    Ok(file)
}

/// Refuses an open file that is not a regular file ([`not_regular`]).
pub fn regular(file: &std::fs::File) -> std::io::Result<()> {
    if file.metadata()?.is_file() {
        return Ok(());
    }
    Err(not_regular())
}

/// The refusal of a FIFO, device or folder where mbs keeps a regular file
/// of its own (`InvalidData`).
pub fn not_regular() -> std::io::Error {
    std::io::Error::new(
        std::io::ErrorKind::InvalidData,
        "not a regular file (a FIFO, device or folder where mbs keeps a file of its own): \
         refused unread",
    )
}

/// [`read_bounded`] of a file of mbs's own ([`open_own_file`]).
pub fn read_own_bounded(path: &Path, bound: Bound<'_>) -> std::io::Result<Vec<u8>> {
    read_file_bounded(open_own_file(path)?, bound)
}

/// [`read_bounded`] of an open file.
fn read_file_bounded(file: std::fs::File, bound: Bound<'_>) -> std::io::Result<Vec<u8>> {
    let len = file.metadata()?.len();
    if len > bound.bytes {
        return Err(too_large(Size(len), bound));
    }
    let mut bytes = Vec::new();
    file.take(bound.bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > bound.bytes {
        return Err(too_large("more", bound));
    }
    Ok(bytes)
}

/// [`read_bounded`] as UTF-8 text.
pub fn read_text_bounded(path: &Path, bound: Bound<'_>) -> std::io::Result<String> {
    utf8(read_bounded(path, bound)?)
}

/// [`read_own_bounded`] as UTF-8 text.
pub fn read_own_text_bounded(path: &Path, bound: Bound<'_>) -> std::io::Result<String> {
    utf8(read_own_bounded(path, bound)?)
}

fn utf8(bytes: Vec<u8>) -> std::io::Result<String> {
    String::from_utf8(bytes).map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
}

/// Reads the next line of `reader` (without its `\n`) into `line`: false at
/// the end; an `InvalidData` error naming the line if it is longer than
/// `bound`, without reading more of it than the bound.
pub fn read_line_bounded(
    reader: &mut impl BufRead,
    line: &mut Vec<u8>,
    number: usize,
    bound: Bound<'_>,
) -> std::io::Result<bool> {
    line.clear();
    reader
        .take(bound.bytes.saturating_add(1))
        .read_until(b'\n', line)?;
    if line.last() == Some(&b'\n') {
        line.pop();
    } else if line.len() as u64 > bound.bytes {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "line {number} is longer than {} ({}): refused unread",
                bound.reason,
                Size(bound.bytes)
            ),
        ));
    } else if line.is_empty() {
        return Ok(false);
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL: Bound = Bound {
        bytes: 10,
        reason: "a test file",
    };

    #[test]
    fn files_beyond_the_bound_are_refused_unread() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f");
        std::fs::write(&path, b"0123456789").unwrap();
        assert_eq!(read_bounded(&path, SMALL).unwrap().len(), 10);
        // Sparse: nothing big is written.
        std::fs::File::options()
            .write(true)
            .open(&path)
            .unwrap()
            .set_len(3 << 30)
            .unwrap();
        let e = read_bounded(&path, SMALL).unwrap_err().to_string();
        assert_eq!(
            e,
            "3 GiB, longer than a test file (10 bytes): refused unread"
        );
        // A device without a length is read only up to the bound.
        if Path::new("/dev/zero").exists() {
            assert!(read_bounded(Path::new("/dev/zero"), SMALL).is_err());
        }
    }

    #[test]
    fn lines_beyond_the_bound_are_refused() {
        let text = b"short\n0123456789\n0123456789A\nlast";
        let mut reader = std::io::BufReader::new(&text[..]);
        let mut line = Vec::new();
        let mut next =
            |n| read_line_bounded(&mut reader, &mut line, n, SMALL).map(|_| line.clone());
        assert_eq!(next(1).unwrap(), b"short");
        assert_eq!(next(2).unwrap(), b"0123456789");
        let e = next(3).unwrap_err().to_string();
        assert!(e.starts_with("line 3 is longer than a test file"), "{e}");
        let mut reader = std::io::BufReader::new(&b"a\nb"[..]);
        let mut lines = Vec::new();
        let mut line = Vec::new();
        let mut n = 0;
        while read_line_bounded(&mut reader, &mut line, n, SMALL).unwrap() {
            lines.push(String::from_utf8(line.clone()).unwrap());
            n += 1;
        }
        assert_eq!(lines, ["a", "b"]);
    }

    #[test]
    fn sizes_in_binary_units() {
        assert_eq!(Size(64 << 20).to_string(), "64 MiB");
        assert_eq!(Size(1536).to_string(), "1.5 KiB");
        assert_eq!(Size(10).to_string(), "10 bytes");
    }
}
