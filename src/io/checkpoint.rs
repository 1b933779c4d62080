//! A small binary container of named arrays, for checkpoint and restart.
//!
//! Layout (little endian): the magic `EMCKPT02`, a `u64` entry count, then per entry a `u64`
//! name length, the UTF-8 name, a `u64` value count and the values as `f64` bit patterns, and
//! last a `u64` checksum of everything before it (see [`checksum`]). `f32` and `f64` values both
//! round-trip exactly through `f64`, so a restarted run continues bit for bit.
//!
//! Files are written atomically ([`super::vtk::write_atomic`]): a failed write (full disk,
//! missing permission) leaves the previous checkpoint intact. A truncated or corrupted file is
//! refused on reading, before any state is touched.

use super::io_error;
use super::vtk::write_atomic;
use crate::{Error, Real, Result};
use std::collections::HashMap;
use std::path::Path;

const MAGIC: &[u8; 8] = b"EMCKPT02";

/// The checksum of the checkpoint format: FNV-1a (64-bit offset basis and prime) applied to
/// `bytes` read as little-endian `u64` words (the last one zero-padded), then xored with the
/// byte count. A change of a single word always changes it (each step is a bijection of the
/// state), and so does zero padding (through the byte count).
pub fn checksum(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for chunk in bytes.chunks(8) {
        let mut w = [0u8; 8];
        w[..chunk.len()].copy_from_slice(chunk);
        h = (h ^ u64::from_le_bytes(w)).wrapping_mul(0x0000_0100_0000_01b3);
    }
    h ^ bytes.len() as u64
}

/// Collects named arrays, then writes them with [`CheckpointWriter::save`].
#[derive(Debug, Default)]
pub struct CheckpointWriter {
    entries: Vec<(String, Vec<f64>)>,
}

impl CheckpointWriter {
    /// An empty checkpoint.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds an array of values; an earlier entry of the same name is replaced.
    pub fn array<T: Real>(&mut self, name: &str, data: &[T]) -> &mut Self {
        self.insert(name, data.iter().map(|x| x.f64()).collect())
    }

    /// Adds a single number (integers up to 2^53 are exact); an earlier entry of the same name
    /// is replaced.
    pub fn number(&mut self, name: &str, x: f64) -> &mut Self {
        self.insert(name, vec![x])
    }

    /// Adds a line of text (stored as its UTF-8 bytes, one value each); an earlier entry of the
    /// same name is replaced.
    pub fn text(&mut self, name: &str, text: &str) -> &mut Self {
        self.insert(name, text.bytes().map(f64::from).collect())
    }

    fn insert(&mut self, name: &str, data: Vec<f64>) -> &mut Self {
        match self.entries.iter_mut().find(|(n, _)| n == name) {
            Some(entry) => entry.1 = data,
            None => self.entries.push((name.to_string(), data)),
        }
        self
    }

    /// The encoded bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = MAGIC.to_vec();
        b.extend_from_slice(&(self.entries.len() as u64).to_le_bytes());
        for (name, data) in &self.entries {
            b.extend_from_slice(&(name.len() as u64).to_le_bytes());
            b.extend_from_slice(name.as_bytes());
            b.extend_from_slice(&(data.len() as u64).to_le_bytes());
            for x in data {
                b.extend_from_slice(&x.to_bits().to_le_bytes());
            }
        }
        let sum = checksum(&b);
        b.extend_from_slice(&sum.to_le_bytes());
        b
    }

    /// Writes the checkpoint atomically to `path`.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        write_atomic(path.as_ref(), &self.to_bytes())
    }
}

/// A checkpoint read back from a file.
#[derive(Debug)]
pub struct CheckpointReader {
    path: String,
    entries: HashMap<String, Vec<f64>>,
}

impl CheckpointReader {
    /// Reads and decodes `path`.
    ///
    /// # Errors
    /// [`Error::Io`] naming `path`: an unreadable file, a wrong header, a checksum that does not
    /// match (a truncated or corrupted file), malformed content.
    pub fn open(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|e| io_error(path, e))?;
        Self::from_bytes(&bytes, &path.display().to_string())
    }

    /// Decodes bytes produced by [`CheckpointWriter::to_bytes`]; `path` is used in messages.
    pub fn from_bytes(bytes: &[u8], path: &str) -> Result<Self> {
        let bad =
            |what: &str| Error::Io { path: path.to_string(), message: format!("not a checkpoint: {what}") };
        if bytes.len() >= 8 && bytes[..8] == b"EMCKPT01"[..] {
            return Err(bad("format EMCKPT01 of an older version (no checksum); write it again"));
        }
        if bytes.len() < 24 || &bytes[..8] != MAGIC {
            return Err(bad("missing header EMCKPT02 or too short"));
        }
        let (content, sum) = bytes.split_at(bytes.len() - 8);
        if checksum(content) != u64::from_le_bytes(sum.try_into().unwrap_or([0; 8])) {
            return Err(bad("checksum mismatch (truncated or corrupted file)"));
        }
        let mut pos: usize = 8;
        let mut take = |n: usize| -> Result<&[u8]> {
            let s =
                pos.checked_add(n).and_then(|end| content.get(pos..end)).ok_or_else(|| bad("truncated"))?;
            pos += n;
            Ok(s)
        };
        let u64_of = |s: &[u8]| u64::from_le_bytes(s.try_into().unwrap_or([0; 8]));
        let count = u64_of(take(8)?) as usize;
        let mut entries = HashMap::new();
        for _ in 0..count {
            let nlen = u64_of(take(8)?) as usize;
            let name = String::from_utf8(take(nlen)?.to_vec()).map_err(|_| bad("name is not UTF-8"))?;
            let len = u64_of(take(8)?) as usize;
            let raw = take(len.checked_mul(8).ok_or_else(|| bad("length overflow"))?)?;
            let data = raw.chunks_exact(8).map(|c| f64::from_bits(u64_of(c))).collect();
            if entries.insert(name, data).is_some() {
                return Err(bad("an entry name appears twice"));
            }
        }
        if pos != content.len() {
            return Err(bad("bytes after the last entry"));
        }
        Ok(CheckpointReader { path: path.to_string(), entries })
    }

    /// The entry `name`, or an error naming it.
    fn entry(&self, name: &str) -> Result<&Vec<f64>> {
        self.entries.get(name).ok_or_else(|| Error::Io {
            path: self.path.clone(),
            message: format!("checkpoint has no entry `{name}`"),
        })
    }

    /// The text `name` (written by [`CheckpointWriter::text`]).
    pub fn text(&self, name: &str) -> Result<String> {
        let bytes: Option<Vec<u8>> = self
            .entry(name)?
            .iter()
            .map(|&x| ((0.0..=255.0).contains(&x) && x.fract() == 0.0).then_some(x as u8))
            .collect();
        bytes.and_then(|b| String::from_utf8(b).ok()).ok_or_else(|| Error::Io {
            path: self.path.clone(),
            message: format!("entry `{name}` is not text"),
        })
    }

    /// The array `name`, which must hold `len` values.
    pub fn array<T: Real>(&self, name: &str, len: usize) -> Result<Vec<T>> {
        let data = self.entry(name)?;
        if data.len() != len {
            return Err(Error::Io {
                path: self.path.clone(),
                message: format!("entry `{name}` has {} values, expected {len} (another grid?)", data.len()),
            });
        }
        Ok(data.iter().map(|&x| T::lit(x)).collect())
    }

    /// The single number `name`.
    pub fn number(&self, name: &str) -> Result<f64> {
        Ok(self.array::<f64>(name, 1)?[0])
    }

    /// Whether the checkpoint holds `name`.
    pub fn has(&self, name: &str) -> bool {
        self.entries.contains_key(name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_is_exact_for_f32_and_f64() {
        let a: Vec<f64> = vec![0.1, -3.0e-300, f64::MAX, 1.0 / 3.0];
        let b: Vec<f32> = vec![0.1, 1.0 / 3.0, f32::MIN_POSITIVE];
        let mut w = CheckpointWriter::new();
        w.array("a", &a).array("b", &b).number("step", 42.0);
        let r = CheckpointReader::from_bytes(&w.to_bytes(), "mem").unwrap();
        assert_eq!(r.array::<f64>("a", 4).unwrap(), a);
        assert_eq!(r.array::<f32>("b", 3).unwrap(), b);
        assert_eq!(r.number("step").unwrap(), 42.0);
        assert!(r.array::<f64>("a", 5).is_err());
        assert!(r.array::<f64>("c", 1).is_err());
        assert!(CheckpointReader::from_bytes(&w.to_bytes()[..20], "mem").is_err());
        assert!(CheckpointReader::from_bytes(b"not a checkpoint", "mem").is_err());
        // A name written twice keeps the last value, and the file stays readable.
        w.number("step", 43.0);
        let r = CheckpointReader::from_bytes(&w.to_bytes(), "mem").unwrap();
        assert_eq!(r.number("step").unwrap(), 43.0);
    }

    #[test]
    fn every_truncation_and_every_flipped_bit_is_refused() {
        let mut w = CheckpointWriter::new();
        w.array("a", &[1.0f64, 2.0, 3.0]).number("step", 7.0);
        let good = w.to_bytes();
        assert!(CheckpointReader::from_bytes(&good, "mem").is_ok());
        for n in 0..good.len() {
            let e = CheckpointReader::from_bytes(&good[..n], "mem").unwrap_err();
            assert!(matches!(e, Error::Io { .. }), "{e}");
        }
        for bit in 0..8 * good.len() {
            let mut bad = good.clone();
            bad[bit / 8] ^= 1 << (bit % 8);
            let e = CheckpointReader::from_bytes(&bad, "mem").unwrap_err();
            assert!(e.to_string().contains("not a checkpoint"), "bit {bit}: {e}");
        }
        let mut longer = good.clone();
        longer.extend_from_slice(&[0; 8]);
        assert!(CheckpointReader::from_bytes(&longer, "mem").is_err());
    }
}
