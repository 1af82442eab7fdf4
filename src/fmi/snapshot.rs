//! FMU states: what `fmi2GetFMUstate` saves, and its checked byte form.
//!
//! A [`Snapshot`] is plain data: the engine's committed state (displacements, applied and set
//! inputs, parameters, history) plus the FMI side (time, state-machine state, experiment).
//! `fmi2GetFMUstate` boxes one; serialization writes it as
//!
//! ```text
//! offset  size  field
//! 0       8     magic "VLRMSTAT"
//! 8       4     format version, u32 LE (STATE_FORMAT_VERSION)
//! 12      4     GUID length g, u32 LE
//! 16      g     GUID, UTF-8 (must equal the instance's GUID)
//! 16+g    8     payload length p, u64 LE
//! 24+g    p     payload: the Snapshot in the binary format of codec.rs
//! 24+g+p  8     checksum: FNV-1a 64 of every byte before it, u64 LE
//! ```
//!
//! No pointers, no padding; every field is checked on the way back in, in the order above,
//! and the first failed check is reported by name.

use super::codec;
use super::fsm::FsmState;
use crate::engine::EngineState;
use serde::{Deserialize, Serialize};

/// First bytes of every serialized state.
pub const STATE_MAGIC: &[u8; 8] = b"VLRMSTAT";
/// Version of the byte layout and payload; bumped on any change to either.
pub const STATE_FORMAT_VERSION: u32 = 2;

/// Everything needed to continue a run from the moment it was taken.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    pub engine: EngineState,
    /// Current communication point.
    pub time: f64,
    /// What `fmi2LastSuccessfulTime` reports.
    pub last_successful_time: f64,
    /// What `fmi2Terminated` reports (true after a discarded step).
    pub wants_to_terminate: bool,
    pub fsm: FsmState,
    pub experiment: Experiment,
}

/// What `fmi2SetupExperiment` recorded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Experiment {
    /// Whether SetupExperiment was called since instantiation or the last reset.
    pub done: bool,
    pub tolerance: Option<f64>,
    pub start_time: f64,
    pub stop_time: Option<f64>,
}

/// FNV-1a, 64 bit.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The byte form of a snapshot taken by the instance with this GUID.
pub fn encode(snapshot: &Snapshot, guid: &str) -> Result<Vec<u8>, String> {
    let payload =
        codec::to_bytes(snapshot).map_err(|e| format!("the state could not be encoded: {e}"))?;
    let guid_len = u32::try_from(guid.len()).map_err(|_| "the GUID is too long".to_string())?;
    let mut out = Vec::with_capacity(32 + guid.len() + payload.len());
    out.extend_from_slice(STATE_MAGIC);
    out.extend_from_slice(&STATE_FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&guid_len.to_le_bytes());
    out.extend_from_slice(guid.as_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&payload);
    let checksum = fnv1a64(&out);
    out.extend_from_slice(&checksum.to_le_bytes());
    Ok(out)
}

/// Read bytes written by [`encode`]; `guid` is the reading instance's GUID.
pub fn decode(bytes: &[u8], guid: &str) -> Result<Snapshot, String> {
    let mut r = Reader { bytes, at: 0 };
    if r.take(8, "magic")? != STATE_MAGIC {
        return Err("magic check failed: the bytes are not a Velarium FMU state".into());
    }
    let version = r.u32("format version")?;
    if version != STATE_FORMAT_VERSION {
        return Err(format!(
            "version check failed: format version {version}, this FMU reads {STATE_FORMAT_VERSION}"
        ));
    }
    let guid_len = r.u32("GUID length")? as usize;
    let saved_guid = r.take(guid_len, "GUID")?;
    let payload_len = r.u64("payload length")?;
    let expected = (r.at as u64)
        .checked_add(payload_len)
        .and_then(|n| n.checked_add(8));
    if expected != Some(bytes.len() as u64) {
        return Err(format!(
            "length check failed: the header announces {} bytes, {} were given (truncated or extended)",
            expected.map_or("too many".to_string(), |n| n.to_string()),
            bytes.len()
        ));
    }
    let body_end = bytes.len() - 8;
    let checksum = u64::from_le_bytes(bytes[body_end..].try_into().expect("8 bytes"));
    if fnv1a64(&bytes[..body_end]) != checksum {
        return Err("checksum check failed: the bytes are corrupted".into());
    }
    if saved_guid != guid.as_bytes() {
        return Err(format!(
            "GUID check failed: the state belongs to GUID {}, this instance has GUID {guid}",
            String::from_utf8_lossy(saved_guid)
        ));
    }
    codec::from_bytes(&bytes[r.at..body_end]).map_err(|e| format!("payload check failed: {e}"))
}

/// A cursor that names the field it could not read.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, field: &str) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or_else(|| {
            format!(
                "length check failed: the bytes end inside the {field} ({} bytes given)",
                self.bytes.len()
            )
        })?;
        let slice = &self.bytes[self.at..end];
        self.at = end;
        Ok(slice)
    }

    fn u32(&mut self, field: &str) -> Result<u32, String> {
        Ok(u32::from_le_bytes(
            self.take(4, field)?.try_into().expect("4 bytes"),
        ))
    }

    fn u64(&mut self, field: &str) -> Result<u64, String> {
        Ok(u64::from_le_bytes(
            self.take(8, field)?.try_into().expect("8 bytes"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Snapshot {
        let scene = crate::Scene::from_json(super::super::instance::TEST_SCENE).unwrap();
        let mut engine = crate::Engine::try_new(scene).unwrap().state().clone();
        engine.displacement[4] = f64::NAN;
        engine.displacement[5] = 0.1 + 0.2;
        Snapshot {
            engine,
            time: 0.30000000000000004,
            last_successful_time: 0.2,
            wants_to_terminate: false,
            fsm: FsmState::StepComplete,
            experiment: Experiment {
                done: true,
                tolerance: None,
                start_time: 0.0,
                stop_time: Some(1.0),
            },
        }
    }

    #[test]
    fn round_trip() {
        let bytes = encode(&sample(), "{abc}").unwrap();
        assert_eq!(&bytes[..8], STATE_MAGIC);
        let back = decode(&bytes, "{abc}").unwrap();
        assert_eq!(back.time.to_bits(), sample().time.to_bits());
        assert!(back.engine.displacement[4].is_nan());
        assert_eq!(
            back.engine.displacement[5].to_bits(),
            (0.1f64 + 0.2).to_bits()
        );
        assert_eq!(back.fsm, FsmState::StepComplete);
    }

    #[test]
    fn every_check_names_itself() {
        let bytes = encode(&sample(), "{abc}").unwrap();
        let check = |b: &[u8], guid: &str, word: &str| {
            let e = decode(b, guid).unwrap_err();
            assert!(e.contains(word), "{e}");
        };
        check(&bytes[..5], "{abc}", "length");
        check(&bytes[..bytes.len() - 3], "{abc}", "length");
        let mut bad = bytes.clone();
        bad[0] = b'X';
        check(&bad, "{abc}", "magic");
        let mut bad = bytes.clone();
        bad[8] = 9;
        check(&bad, "{abc}", "version");
        let mut bad = bytes.clone();
        let n = bad.len();
        bad[n - 12] ^= 0x40;
        check(&bad, "{abc}", "checksum");
        check(&bytes, "{xyz}", "GUID");
        for cut in 0..bytes.len() {
            assert!(decode(&bytes[..cut], "{abc}").is_err());
        }
    }
}
