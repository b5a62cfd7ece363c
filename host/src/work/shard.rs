//! Sweeps over many machines: a slice of the cells (`--shard I/N`), and
//! the merge of the slices' cell stores into one directory, where the
//! command run again finds every cell and writes the whole result.

use crate::error::HostError;
use crate::work::store::{Store, STORE};
use std::path::{Path, PathBuf};

/// One slice of a run's or a stage's cells: `index` of `count`
/// (`--shard I/N`, I = index + 1); cell k belongs to slice k mod count.
///
/// ```
/// use mbs::work::shard::Shard;
///
/// let s: Shard = "2/3".parse().unwrap();
/// assert_eq!((s.index, s.count), (1, 3));
/// assert!(s.owns(1) && s.owns(4) && !s.owns(2));
/// assert!("0/3".parse::<Shard>().is_err() && "4/3".parse::<Shard>().is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// 0-based slice index.
    pub index: usize,
    /// Number of slices.
    pub count: usize,
}

impl Shard {
    /// Every cell.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Whether this slice computes cell number `cell`.
    pub fn owns(self, cell: usize) -> bool {
        cell % self.count == self.index
    }

    /// Whether this is every cell.
    pub fn is_all(self) -> bool {
        self.count == 1
    }
}

impl Default for Shard {
    /// [`Shard::ALL`].
    fn default() -> Self {
        Shard::ALL
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// `I/N`, 1 ≤ I ≤ N.
    fn from_str(text: &str) -> Result<Shard, String> {
        let bad = || format!("{text}: must be I/N with 1 <= I <= N, e.g. 3/8");
        let (i, n) = text.split_once('/').ok_or_else(bad)?;
        let (i, n): (usize, usize) = (
            i.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if i == 0 || i > n {
            return Err(bad());
        }
        Ok(Shard {
            index: i - 1,
            count: n,
        })
    }
}

/// Adds the cells of the shard directories `shards` to `dir`'s cell store
/// (`mbs merge`, `mbs calibrate merge`); returns how many were new.
pub fn merge(shards: &[PathBuf], dir: &Path) -> Result<usize, HostError> {
    let _lock = crate::io::output::lock_dir(dir)?;
    let store = Store::open(&dir.join(STORE))?;
    let mut added = 0;
    for shard in shards {
        let path = shard.join(STORE);
        if !path.is_file() {
            return Err(HostError::io(&path)(std::io::Error::new(
                std::io::ErrorKind::NotFound,
                "no cell store here: is this a shard's --out directory?",
            )));
        }
        added += store.merge_from(&path)?;
    }
    Ok(added)
}
