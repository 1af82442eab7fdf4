//! Allocations that grow with the input, made fallible.
//!
//! Stable Rust aborts the process when an allocation fails (there is no allocation-error hook),
//! and inside an FMU that abort takes the importing host down. So every buffer whose size
//! follows the scene is obtained here, through `try_reserve_exact`, and a failure comes back as
//! [`OutOfMemory`] naming what could not be had and how much:
//!
//! ```text
//! zeros / filled / collect / copy   the big buffers we own (mesh, model arrays, pattern and
//!                                   position maps, matrix and factor values, state vectors)
//! probe(bytes)                      reserve and release a phase's whole working set before the
//!                                   phase runs (validation, model build, every step): the
//!                                   many small allocations inside it then fit in what the
//!                                   probe showed to be there
//! ```
//! Small fixed-size allocations (a few KB: messages, per-scene tables) stay infallible
//! (docs/fmu.md, what we guarantee about memory).

use std::fmt;

/// An allocation that could not be made.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutOfMemory {
    /// What the memory was for ("the tangent's factor", "the mesh", ...).
    pub what: &'static str,
    /// Bytes asked for.
    pub bytes: u64,
}

/// The size of an [`OutOfMemory`] that is no allocation's failure: what it names is larger
/// than the solver's indices address (its message then says so and names the limit).
pub const UNADDRESSABLE: u64 = u64::MAX;

impl fmt::Display for OutOfMemory {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.bytes == UNADDRESSABLE {
            return write!(
                f,
                "too large: {} (the scene passed its size limits, but the solver cannot index that much); nothing was changed",
                self.what
            );
        }
        write!(
            f,
            "out of memory: {:.1} MB for {} could not be allocated (the scene passed its size limits, but this process cannot get that much memory now: the machine's free memory or the process's address-space limit is lower); nothing was changed",
            self.bytes as f64 / 1e6,
            self.what
        )
    }
}

impl std::error::Error for OutOfMemory {}

fn bytes_of<T>(n: usize) -> u64 {
    (n as u64).saturating_mul(std::mem::size_of::<T>() as u64)
}

/// An empty vector with room for exactly `n` elements.
pub fn with_capacity<T>(n: usize, what: &'static str) -> Result<Vec<T>, OutOfMemory> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| OutOfMemory {
        what,
        bytes: bytes_of::<T>(n),
    })?;
    Ok(v)
}

/// `vec![value; n]`, fallible.
pub fn filled<T: Clone>(n: usize, value: T, what: &'static str) -> Result<Vec<T>, OutOfMemory> {
    let mut v = with_capacity(n, what)?;
    v.resize(n, value);
    Ok(v)
}

/// `vec![T::default(); n]`, fallible.
pub fn zeros<T: Clone + Default>(n: usize, what: &'static str) -> Result<Vec<T>, OutOfMemory> {
    filled(n, T::default(), what)
}

/// `vec![T::default(); n]` for a number type whose default is all zero bits, with its pages
/// left to the first write: the standard library asks the allocator for zeroed memory, which
/// for a large block is fresh pages from the system, zero-filled only when first touched (by
/// the thread that writes them). [`probe`] checks the bytes fallibly first, as for faer's
/// dense matrices (`solver/split.rs`); only a shortage between the probe and the allocation
/// would abort. For the largest buffers (the factor's values): the setup then costs no pass
/// over them, and on two threads each half's factor is touched by the thread that factors it.
pub fn lazy_zeros<T: Clone + Default>(n: usize, what: &'static str) -> Result<Vec<T>, OutOfMemory> {
    probe(bytes_of::<T>(n), what)?;
    Ok(vec![T::default(); n])
}

/// Collect an iterator of known length, fallible (the length is reserved exactly first; an
/// iterator longer than it says grows the vector infallibly).
pub fn collect<T, I>(iter: I, what: &'static str) -> Result<Vec<T>, OutOfMemory>
where
    I: IntoIterator<Item = T>,
    I::IntoIter: ExactSizeIterator,
{
    let iter = iter.into_iter();
    let mut v = with_capacity(iter.len(), what)?;
    v.extend(iter);
    Ok(v)
}

/// A copy of a slice, fallible.
pub fn copy<T: Clone>(from: &[T], what: &'static str) -> Result<Vec<T>, OutOfMemory> {
    let mut v = with_capacity(from.len(), what)?;
    v.extend_from_slice(from);
    Ok(v)
}

/// Make sure `bytes` more can be had now: reserve them and give them back. Run before a phase
/// whose allocations sum to at most `bytes`, so that a shortage is found before the phase
/// starts, not in the middle of it. Reserving touches no page, so the probe costs a map and an
/// unmap, not the bytes.
pub fn probe(bytes: u64, what: &'static str) -> Result<(), OutOfMemory> {
    let fail = OutOfMemory { what, bytes };
    let n = usize::try_from(bytes).map_err(|_| fail.clone())?;
    let mut v: Vec<u8> = Vec::new();
    v.try_reserve_exact(n).map_err(|_| fail)?;
    drop(v);
    Ok(())
}

/// The process's peak resident set in bytes (VmHWM of /proc/self/status: the most physical
/// memory it has held at once, its own and every library's), None where that file is missing
/// (not Linux). What a user compares with the engine's estimate (`Engine::memory_estimate`).
pub fn peak_resident() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// "estimated X MB, peak resident Y MB" (the peak omitted where unknown), for the CLI's and
/// the FMU's logs.
pub fn report(estimate: u64) -> String {
    let mb = |b: u64| {
        let mb = b as f64 / 1e6;
        if mb >= 100.0 {
            format!("{mb:.0} MB")
        } else {
            format!("{mb:.3} MB")
        }
    };
    match peak_resident() {
        Some(peak) => format!(
            "memory: estimated {} for model and solver, peak resident {} (whole process)",
            mb(estimate),
            mb(peak)
        ),
        None => format!("memory: estimated {} for model and solver", mb(estimate)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_impossible_request_is_an_error_not_an_abort() {
        // More than any address space: try_reserve fails (capacity overflow or the allocator
        // says no) and we get the error back.
        let e = filled(usize::MAX / 16, 0.0f64, "a test buffer").unwrap_err();
        assert_eq!(e.what, "a test buffer");
        assert!(e.to_string().starts_with("out of memory:"), "{e}");
        assert!(probe(u64::MAX / 2, "a probe").is_err());
        assert!(probe(1 << 20, "a probe").is_ok());
        assert_eq!(zeros::<u8>(3, "x").unwrap(), vec![0, 0, 0]);
        assert_eq!(collect(0..4, "x").unwrap(), vec![0, 1, 2, 3]);
    }
}
