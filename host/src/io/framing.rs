//! The framing shared by the host's checkpoint files (cells and settled
//! beds): a four-byte magic, a u16 format version, a little-endian body and
//! a CRC-32 (IEEE) of everything before it. The CRC detects damage, not
//! deliberate edits: each file's reader checks every field it decodes.

/// Why a checkpoint file was refused.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CheckpointError {
    /// Shorter than its contents.
    Truncated,
    /// Not this kind of checkpoint (its magic).
    Magic(&'static str),
    /// Another format version.
    Version {
        /// The file's.
        found: u16,
        /// This mbs's.
        reads: u16,
    },
    /// Checksum mismatch: damaged.
    Checksum,
    /// Written for another configuration, τ* or seed.
    OtherCell,
    /// A field is out of range.
    Value(&'static str),
}

impl std::fmt::Display for CheckpointError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CheckpointError::Truncated => write!(f, "truncated"),
            CheckpointError::Magic(what) => write!(f, "not an mbs {what}"),
            CheckpointError::Version { found, reads } => {
                write!(f, "format version {found}, this mbs reads {reads}")
            }
            CheckpointError::Checksum => write!(f, "checksum mismatch (damaged)"),
            CheckpointError::OtherCell => {
                write!(f, "written for another configuration, tau* or seed")
            }
            CheckpointError::Value(what) => write!(f, "{what} out of range"),
        }
    }
}

/// A file being written: the magic and version first, [`Writer::seal`]
/// appends the CRC.
///
/// ```
/// use mbs::io::framing::{Reader, Writer};
///
/// let mut w = Writer::new(*b"TEST", 1);
/// w.u64(7);
/// w.f64(0.5);
/// w.bytes(&[1, 2, 3]);
/// let file = w.seal();
/// let mut r = Reader::open(&file, *b"TEST", 1, "test file")?;
/// assert_eq!((r.u64()?, r.f64()?, r.bytes()?), (7, 0.5, &[1u8, 2, 3][..]));
/// r.finish()?;
/// assert!(Reader::open(&file[..file.len() - 1], *b"TEST", 1, "test file").is_err());
/// # Ok::<(), mbs::io::framing::CheckpointError>(())
/// ```
pub struct Writer(Vec<u8>);

impl Writer {
    /// A file of kind `magic`, format `version`.
    pub fn new(magic: [u8; 4], version: u16) -> Writer {
        let mut b = Vec::with_capacity(256);
        b.extend_from_slice(&magic);
        b.extend_from_slice(&version.to_le_bytes());
        Writer(b)
    }

    /// Appends a byte.
    pub fn u8(&mut self, x: u8) {
        self.0.push(x);
    }

    /// Appends a u32.
    pub fn u32(&mut self, x: u32) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }

    /// Appends a u64.
    pub fn u64(&mut self, x: u64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }

    /// Appends an f64's bits.
    pub fn f64(&mut self, x: f64) {
        self.u64(x.to_bits());
    }

    /// Appends a length (u64) and the bytes.
    pub fn bytes(&mut self, b: &[u8]) {
        self.u64(b.len() as u64);
        self.0.extend_from_slice(b);
    }

    /// The file: everything written and its CRC-32.
    pub fn seal(mut self) -> Vec<u8> {
        let sum = crc32fast::hash(&self.0);
        self.0.extend_from_slice(&sum.to_le_bytes());
        self.0
    }

    /// The bytes of magic, version and CRC: what a file holds besides its
    /// fields.
    pub const OVERHEAD: usize = 4 + 2 + 4;
}

/// A file being read, after its magic, version and CRC were checked.
pub struct Reader<'a> {
    body: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// Checks `bytes`' magic (a `what` file), version and CRC, in that
    /// order, and positions after the version.
    pub fn open(
        bytes: &'a [u8],
        magic: [u8; 4],
        version: u16,
        what: &'static str,
    ) -> Result<Reader<'a>, CheckpointError> {
        if bytes.len() < 6 {
            return Err(if bytes.starts_with(&magic[..bytes.len().min(4)]) {
                CheckpointError::Truncated
            } else {
                CheckpointError::Magic(what)
            });
        }
        if bytes[..4] != magic {
            return Err(CheckpointError::Magic(what));
        }
        let found = u16::from_le_bytes([bytes[4], bytes[5]]);
        if found != version {
            return Err(CheckpointError::Version {
                found,
                reads: version,
            });
        }
        if bytes.len() < Writer::OVERHEAD {
            return Err(CheckpointError::Truncated);
        }
        let (body, sum) = bytes.split_at(bytes.len() - 4);
        if crc32fast::hash(body).to_le_bytes() != sum {
            return Err(CheckpointError::Checksum);
        }
        Ok(Reader { body, at: 6 })
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], CheckpointError> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&e| e <= self.body.len())
            .ok_or(CheckpointError::Truncated)?;
        let out = &self.body[self.at..end];
        self.at = end;
        Ok(out)
    }

    /// The next byte.
    pub fn u8(&mut self) -> Result<u8, CheckpointError> {
        Ok(self.take(1)?[0])
    }

    /// The next u32.
    pub fn u32(&mut self) -> Result<u32, CheckpointError> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// The next u64.
    pub fn u64(&mut self) -> Result<u64, CheckpointError> {
        let mut a = [0u8; 8];
        a.copy_from_slice(self.take(8)?);
        Ok(u64::from_le_bytes(a))
    }

    /// The next f64.
    pub fn f64(&mut self) -> Result<f64, CheckpointError> {
        Ok(f64::from_bits(self.u64()?))
    }

    /// The next length-prefixed bytes.
    pub fn bytes(&mut self) -> Result<&'a [u8], CheckpointError> {
        let len = usize::try_from(self.u64()?).map_err(|_| CheckpointError::Truncated)?;
        self.take(len)
    }

    /// Ok if every byte before the CRC was read.
    pub fn finish(self) -> Result<(), CheckpointError> {
        if self.at == self.body.len() {
            Ok(())
        } else {
            Err(CheckpointError::Value("length"))
        }
    }
}
