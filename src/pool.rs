//! Host buffers reused across frames: the GPU's read-back writes a frame's bytes into a
//! buffer whose pages an earlier frame already touched, instead of fresh pages the kernel
//! must fault in and zero first (measured on an H200 host: a 4096x4096 frame's 48 MiB fill
//! fresh pages at about 5 GB/s, which doubles the read-back; issue 52).
//!
//! The pool is the process's, so the layers that fill buffers (the GPU wings) and those that
//! finish with them (`animate.rs`'s encoder threads) meet without passing it around. A
//! buffer taken keeps its previous bytes up to the length asked for: its taker overwrites
//! every byte (the 8-bit read-backs do; the tests check that no frame shows a previous
//! frame's bytes, frames of different sizes in one process included).

use std::sync::Mutex;

/// Buffers kept at most: the frames an animation has in flight (one rendering, two
/// queued, up to four encoding) and one more.
const KEEP: usize = 8;

/// Buffers handed back, for the next taker.
pub struct Pool(Mutex<Vec<Vec<u8>>>);

static POOL: Pool = Pool::new();

/// [`Pool::take`] from the process's pool.
pub fn take(len: usize) -> Vec<u8> {
    POOL.take(len)
}

/// [`Pool::give_back`] to the process's pool.
pub fn give_back(buf: Vec<u8>) {
    POOL.give_back(buf)
}

impl Pool {
    /// An empty pool.
    pub const fn new() -> Self {
        Pool(Mutex::new(Vec::new()))
    }

    /// A buffer of `len` bytes: a pooled one whose capacity holds `len` (the smallest
    /// such, its old bytes left in place: the caller overwrites every one), else a new
    /// zeroed one.
    pub fn take(&self, len: usize) -> Vec<u8> {
        let reused = {
            let mut pool = self.0.lock().unwrap_or_else(|e| e.into_inner());
            let best = pool
                .iter()
                .enumerate()
                .filter(|(_, b)| b.capacity() >= len)
                .min_by_key(|(_, b)| b.capacity())
                .map(|(k, _)| k);
            best.map(|k| pool.swap_remove(k))
        };
        match reused {
            Some(mut b) => {
                // Growing within the capacity writes zeros past the old length only.
                b.resize(len, 0);
                b
            }
            None => vec![0u8; len],
        }
    }

    /// Hands `buf` back for a later [`Pool::take`]; when the pool is full the smallest
    /// buffer is freed instead.
    pub fn give_back(&self, buf: Vec<u8>) {
        if buf.capacity() == 0 {
            return;
        }
        let mut pool = self.0.lock().unwrap_or_else(|e| e.into_inner());
        pool.push(buf);
        if pool.len() > KEEP {
            let smallest = pool
                .iter()
                .enumerate()
                .min_by_key(|(_, b)| b.capacity())
                .map(|(k, _)| k)
                .expect("not empty");
            pool.swap_remove(smallest);
        }
    }
}

impl Default for Pool {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A buffer handed back comes back (same allocation) for a request it can hold, at the
    /// length asked, and a larger request gets a buffer that holds it.
    #[test]
    fn buffers_come_back_at_the_length_asked() {
        let pool = Pool::new();
        let a = pool.take(1000);
        assert_eq!(a.len(), 1000);
        let at = a.as_ptr();
        pool.give_back(a);
        let b = pool.take(999);
        assert_eq!((b.len(), b.as_ptr()), (999, at), "the same pages");
        pool.give_back(b);
        let c = pool.take(1000);
        assert_eq!(
            (c.len(), c.as_ptr()),
            (1000, at),
            "grown back within capacity"
        );
        let d = pool.take(2000);
        assert_eq!(d.len(), 2000);
        assert_ne!(d.as_ptr(), at);
        pool.give_back(d);
        // The smallest buffer that holds a request serves it.
        let e = pool.take(10);
        assert_eq!(e.len(), 10);
        assert_eq!(e.capacity(), 2000, "the only one pooled");
        pool.give_back(c);
        pool.give_back(e);
        let f = pool.take(10);
        assert_eq!(f.as_ptr(), at, "the smaller of the two");
        // A full pool frees its smallest buffer.
        for n in 1..=2 * KEEP {
            pool.give_back(Vec::with_capacity(100 * n));
        }
        let kept = pool.0.lock().unwrap();
        assert_eq!(kept.len(), KEEP);
        assert!(
            kept.iter().all(|b| b.capacity() >= 100 * (KEEP + 1)),
            "largest kept"
        );
    }
}
