//! The program-binary cache of our own: linked programs saved with `glGetProgramBinary` and
//! loaded with `glProgramBinary`, so a second process (the next run, another task of a farm,
//! a CI job on a GPU runner whose driver cache is empty) skips compiling and linking.
//!
//! An entry is one file, named by two hashes: the driver's (vendor, renderer, GL version
//! and fragtrace's own version) and the full source the program is linked from (every
//! shader's text, `#define`s included, and the pass name). It starts with a header (magic,
//! both hashes, the binary's format, its length and a checksum of its bytes): a file that
//! is truncated, corrupt or written for another key is refused here, before GL sees it, and
//! a binary the driver no longer accepts (a driver update behind the same strings) fails
//! its link status in `gl::program::link_binary`; either way the program is compiled from
//! source and the entry rewritten. Entries are written to a temporary file and renamed into
//! place, so processes sharing the folder never read a torn one. Every failure to read or
//! write the folder only means compiling, never an error.
//!
//! Where: `$FRAGTRACE_SHADER_CACHE_DIR`, else `$XDG_CACHE_HOME/fragtrace`, else
//! `~/.cache/fragtrace`, subfolder `programs`. Whether: `--shader-cache on|off`, whose
//! default is `$FRAGTRACE_SHADER_CACHE` (decided in `choices.rs`), and only on a context
//! offering at least one binary format (GL 4.1 or `GL_ARB_get_program_binary`).

use std::cell::Cell;
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::fnv::Fnv64;
pub use crate::gpu::gl::program::Binary;
use crate::gpu::info::GlInfo;

/// Environment variable naming the cache's folder (its `programs` subfolder holds entries).
pub const DIR_ENV: &str = "FRAGTRACE_SHADER_CACHE_DIR";

/// First bytes of every entry; the digit is the header's version.
const MAGIC: &[u8; 8] = b"FTPROGB1";
/// Header bytes: magic, driver hash, source hash, format, payload length, payload checksum.
const HEADER: usize = 8 + 8 + 8 + 4 + 8 + 8;

/// How a cache lookup or store went, counted per cache (reported in the render's stats).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CacheCounts {
    /// Programs linked from a cached binary.
    pub hits: u32,
    /// Programs with no entry (compiled, then stored).
    pub misses: u32,
    /// Entries refused: truncated, corrupt, for another key, or not accepted by the driver
    /// (compiled and rewritten).
    pub rejected: u32,
    /// Entries written.
    pub stored: u32,
}

/// The key of one program: the hash of the sources it is linked from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SourceKey(u64);

impl SourceKey {
    /// The key of a program called `pass` linked from `sources` in order.
    pub fn of(pass: &str, sources: &[&str]) -> Self {
        let mut h = Fnv64::new();
        h.write_str(pass);
        for s in sources {
            h.write_str(s);
        }
        SourceKey(h.finish())
    }
}

/// The cache folder of one driver (see the module docs).
#[derive(Debug)]
pub struct ProgramCache {
    dir: PathBuf,
    driver: u64,
    counts: Cell<CacheCounts>,
}

impl ProgramCache {
    /// The default folder (see the module docs), or None when neither it nor a home folder
    /// is known.
    pub fn default_dir() -> Option<PathBuf> {
        let var = |k: &str| {
            std::env::var_os(k)
                .filter(|v| !v.is_empty())
                .map(PathBuf::from)
        };
        let root = var(DIR_ENV)
            .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("fragtrace")))
            .or_else(|| var("HOME").map(|d| d.join(".cache").join("fragtrace")))?;
        Some(root.join("programs"))
    }

    /// The cache in the default folder for the driver `info` describes, or None where the
    /// context offers no binary format or no folder is known.
    pub fn open(info: &GlInfo) -> Option<Self> {
        Self::at(&Self::default_dir()?, info)
    }

    /// The cache in folder `dir` (created on the first store) for the driver `info`
    /// describes, or None where the context offers no binary format.
    pub fn at(dir: &Path, info: &GlInfo) -> Option<Self> {
        if info.program_binary_formats < 1 {
            return None;
        }
        let mut h = Fnv64::new();
        for s in [
            info.vendor.as_str(),
            info.renderer.as_str(),
            info.gl_version.as_str(),
            env!("CARGO_PKG_VERSION"),
        ] {
            h.write_str(s);
        }
        Some(ProgramCache {
            dir: dir.to_path_buf(),
            driver: h.finish(),
            counts: Cell::new(CacheCounts::default()),
        })
    }

    /// What this cache has done so far.
    pub fn counts(&self) -> CacheCounts {
        self.counts.get()
    }

    /// The file of entry `key`.
    pub fn entry_path(&self, key: SourceKey) -> PathBuf {
        self.dir
            .join(format!("{:016x}-{:016x}.bin", self.driver, key.0))
    }

    /// The marker of entry `key`: an earlier process started its compile on the driver's
    /// threads and ended before the driver finished it (a single frame that `--kernel
    /// auto`'s cold start rendered on the looped kernel), so the compile died with it.
    fn unfinished_path(&self, key: SourceKey) -> PathBuf {
        self.dir
            .join(format!("{:016x}-{:016x}.unfinished", self.driver, key.0))
    }

    /// Marks entry `key` as a compile left unfinished (see [`ProgramCache::was_unfinished`]).
    /// Failures are ignored: the next run then starts the compile on the driver's threads
    /// again.
    pub fn mark_unfinished(&self, key: SourceKey) {
        let _ = std::fs::create_dir_all(&self.dir)
            .and_then(|()| std::fs::File::create(self.unfinished_path(key)).map(drop));
    }

    /// Whether an earlier process left the compile of entry `key` unfinished: the next run
    /// that needs it waits for its compile rather than starting it again on the driver's
    /// threads, so that the process after it finds the binary (a user who renders one
    /// frame at a time pays the compile once, on the second run, instead of never getting
    /// the faster kernel). Storing the entry removes the marker.
    pub fn was_unfinished(&self, key: SourceKey) -> bool {
        self.unfinished_path(key).is_file()
    }

    /// The binary stored for `key`, checked against its header; None (counted as a miss or
    /// a rejection) when there is none or it cannot be trusted.
    pub fn load(&self, key: SourceKey) -> Option<Binary> {
        let bytes = match std::fs::read(self.entry_path(key)) {
            Ok(b) => b,
            Err(_) => {
                self.count(|c| c.misses += 1);
                return None;
            }
        };
        let binary = self.parse(key, &bytes);
        if binary.is_none() {
            self.count(|c| c.rejected += 1);
        }
        binary
    }

    /// Counts a binary [`ProgramCache::load`] returned that the driver then refused.
    pub fn refused(&self) {
        self.count(|c| c.rejected += 1);
    }

    /// Counts a binary the driver accepted.
    pub fn hit(&self) {
        self.count(|c| c.hits += 1);
    }

    /// Writes `binary` as entry `key`: to a temporary file beside it, then renamed over it,
    /// so a reader sees the old entry, the new one or none. Failures are ignored (the next
    /// run compiles again).
    pub fn store(&self, key: SourceKey, binary: &Binary) {
        if binary.bytes.is_empty() {
            return;
        }
        let path = self.entry_path(key);
        let tmp = self.dir.join(format!(
            ".{:016x}-{:016x}.{}.{:?}.tmp",
            self.driver,
            key.0,
            std::process::id(),
            std::thread::current().id()
        ));
        let write = || -> std::io::Result<()> {
            std::fs::create_dir_all(&self.dir)?;
            let mut f = std::fs::File::create(&tmp)?;
            f.write_all(&self.header(key, binary))?;
            f.write_all(&binary.bytes)?;
            f.sync_all()?;
            std::fs::rename(&tmp, &path)
        };
        if write().is_ok() {
            let _ = std::fs::remove_file(self.unfinished_path(key));
            self.count(|c| c.stored += 1);
        } else {
            let _ = std::fs::remove_file(&tmp);
        }
    }

    fn header(&self, key: SourceKey, binary: &Binary) -> Vec<u8> {
        let mut h = Vec::with_capacity(HEADER);
        h.extend_from_slice(MAGIC);
        h.extend_from_slice(&self.driver.to_le_bytes());
        h.extend_from_slice(&key.0.to_le_bytes());
        h.extend_from_slice(&binary.format.to_le_bytes());
        h.extend_from_slice(&(binary.bytes.len() as u64).to_le_bytes());
        h.extend_from_slice(&checksum(&binary.bytes).to_le_bytes());
        h
    }

    /// The binary in `bytes` where its header matches `key`, its length and its checksum.
    fn parse(&self, key: SourceKey, bytes: &[u8]) -> Option<Binary> {
        let (head, payload) = (bytes.get(..HEADER)?, &bytes[HEADER.min(bytes.len())..]);
        let u64_at = |at: usize| u64::from_le_bytes(head[at..at + 8].try_into().expect("8"));
        let format = u32::from_le_bytes(head[24..28].try_into().expect("4"));
        let ok = &head[..8] == MAGIC
            && u64_at(8) == self.driver
            && u64_at(16) == key.0
            && u64_at(28) == payload.len() as u64
            && u64_at(36) == checksum(payload);
        ok.then(|| Binary {
            format,
            bytes: payload.to_vec(),
        })
    }

    fn count(&self, f: impl FnOnce(&mut CacheCounts)) {
        let mut c = self.counts.get();
        f(&mut c);
        self.counts.set(c);
    }
}

/// The payload's checksum.
fn checksum(bytes: &[u8]) -> u64 {
    let mut h = Fnv64::new();
    h.write(bytes);
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info() -> GlInfo {
        let mut i = crate::gpu::info::tests::sample_info();
        i.program_binary_formats = 1;
        i
    }

    fn temp_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("fragtrace-pc-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    /// An entry reads back as written; every truncation, every flipped byte of header and
    /// payload, another source key and another driver are refused and counted, never
    /// returned.
    #[test]
    fn entries_round_trip_and_damaged_ones_are_refused() {
        let dir = temp_dir("roundtrip");
        let cache = ProgramCache::at(&dir, &info()).unwrap();
        let key = SourceKey::of("step", &["void main() {}"]);
        assert_eq!(cache.load(key), None);
        let b = Binary {
            format: 0x8764,
            bytes: (0..300u32).map(|i| (i * 7) as u8).collect(),
        };
        cache.store(key, &b);
        assert_eq!(cache.load(key), Some(b.clone()));
        let path = cache.entry_path(key);
        let good = std::fs::read(&path).unwrap();
        let mut refused = 0;
        for cut in 0..good.len() {
            std::fs::write(&path, &good[..cut]).unwrap();
            assert_eq!(cache.load(key), None, "cut at {cut}");
            refused += 1;
        }
        for at in 0..good.len() {
            let mut bad = good.clone();
            bad[at] ^= 0x10;
            std::fs::write(&path, &bad).unwrap();
            // Flipping the format's bytes is no damage the header can see: the driver's
            // link status catches that one (`gl::program::link_binary`).
            if (24..28).contains(&at) {
                continue;
            }
            assert_eq!(cache.load(key), None, "byte {at} flipped");
            refused += 1;
        }
        std::fs::write(&path, &good).unwrap();
        let other = SourceKey::of("step", &["void main() { }"]);
        std::fs::copy(&path, cache.entry_path(other)).unwrap();
        assert_eq!(cache.load(other), None, "another key's entry");
        let mut i2 = info();
        i2.gl_version.push_str(" (updated)");
        let other_driver = ProgramCache::at(&dir, &i2).unwrap();
        std::fs::copy(&path, other_driver.entry_path(key)).unwrap();
        assert_eq!(other_driver.load(key), None, "another driver's entry");
        let c = cache.counts();
        assert_eq!((c.hits, c.misses, c.stored), (0, 1, 1));
        assert_eq!(c.rejected, refused + 1);
        // No temporary file is left behind.
        let names: Vec<_> = std::fs::read_dir(&dir).unwrap().flatten().collect();
        assert!(names
            .iter()
            .all(|e| !e.file_name().to_string_lossy().ends_with(".tmp")));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A context without a binary format gets no cache; the source key tells sources apart
    /// that only their split into shaders distinguishes.
    #[test]
    fn no_cache_without_formats_and_keys_see_the_split() {
        let mut i = info();
        i.program_binary_formats = 0;
        assert!(ProgramCache::at(Path::new("/nonexistent"), &i).is_none());
        assert_ne!(
            SourceKey::of("p", &["ab", "c"]),
            SourceKey::of("p", &["a", "bc"])
        );
        assert_ne!(SourceKey::of("p", &["a"]), SourceKey::of("q", &["a"]));
    }
}
