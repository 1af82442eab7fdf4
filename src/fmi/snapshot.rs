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
//! 24+g    p     payload: the Snapshot in postcard 1's wire format
//! 24+g+p  8     checksum: FNV-1a 64 of every byte before it, u64 LE
//! ```
//!
//! No pointers, no padding; every field is checked on the way back in, in the order above,
//! and the first failed check is reported by name. Format versions: 2 added the sleeve slips;
//! 3 writes the payload with postcard (varint lengths and integers) instead of the fixed-width
//! format of version 2 (which was byte for byte bincode 1's), so a version 2 state is refused
//! by the version check; 4 appends the sleeve ties' multipliers (3 per tie, model/sleeve.rs) to
//! the engine's unknown vector `engine.displacement`. The payload's layout is 3's, so a
//! version 3 state is still read: [`upgrade`] gives it multipliers 0 (the penalty equilibrium
//! it holds; the next step closes the ties). 5 appends the plastic strains of the membrane
//! triangles (`EngineState::plastic`, 4 per triangle of an elastoplastic model, empty
//! otherwise) to the engine's state; 3 and 4 are read through [`Legacy`] with no plastic
//! strain (neither could hold an elastoplastic model). 6 appends the velocities and
//! accelerations of a scene with time integration (`EngineState::velocity`, `acceleration`,
//! 3 per node, empty in a quasi-static scene); 5 is read through [`Legacy5`] with none (it
//! could not hold a dynamic scene).
//!
//! The payload format is postcard's (fields in declaration order, no names; `f64` as its IEEE bits,
//! little-endian, so NaN payloads and ±Inf come back bit for bit; lengths, enum tags and integers
//! wider than a byte as varints; bool and Option tags 0 or 1, anything else an error). It replaced
//! a hand-written serde format of 469 lines (535 with its tests). Measured when it did (the tests
//! below and in `tests/guards/fmu_state_codec.rs` keep the properties): every truncation, bit flip and
//! byte overwrite of a payload decodes to an error or a value, never a panic; a length prefix
//! larger than the bytes left allocates nothing for it (postcard then gives serde no size hint; the
//! old format let serde preallocate up to 1 MiB per vector); the output is deterministic; the
//! shipped scenes' states are 52-55 bytes smaller (lengths of 1-3 bytes instead of 8:
//! AnnulusTorsion 44778 -> 44726 bytes, PrestressedCable 274 -> 219). What postcard does not give:
//! serde's own messages (a wrong enum tag reads "Serde Deserialization Error", without the tag).
//! bincode was the other candidate: unmaintained, its last release (3.0.0) does not compile by
//! design.

use super::fsm::FsmState;
use crate::engine::EngineState;
use crate::error::Error;
use serde::{Deserialize, Serialize};

/// First bytes of every serialized state.
pub const STATE_MAGIC: &[u8; 8] = b"VLRMSTAT";
/// Version of the byte layout and payload; bumped on any change to either.
pub const STATE_FORMAT_VERSION: u32 = 6;
/// The oldest version [`decode`] reads (module docs: 3 is 4 without the tie multipliers, 4 is
/// 5 without the plastic strains, 5 is 6 without the velocities and accelerations).
pub const OLDEST_STATE_FORMAT_VERSION: u32 = 3;

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

/// The payload of format versions 3 and 4: [`Snapshot`] whose engine state ends before the
/// plastic strains (postcard writes fields in order, without names or counts).
#[derive(Deserialize)]
struct Legacy {
    engine: LegacyEngine,
    time: f64,
    last_successful_time: f64,
    wants_to_terminate: bool,
    fsm: FsmState,
    experiment: Experiment,
}

/// [`EngineState`] of format versions 3 and 4.
#[derive(Deserialize)]
struct LegacyEngine {
    displacement: Vec<f64>,
    slip_state: Vec<crate::model::sleeve::Contact>,
    applied: Vec<f64>,
    inputs: Vec<f64>,
    parameters: Vec<f64>,
    last_iterations: u32,
    wrinkle: Vec<crate::model::wrinkling::WrinkleState>,
    tension_angle: Vec<f64>,
}

impl From<Legacy> for Snapshot {
    /// Format 5's reading with no plastic strain (neither 3 nor 4 could hold one).
    fn from(l: Legacy) -> Snapshot {
        let e = l.engine;
        Legacy5 {
            engine: Engine5 {
                displacement: e.displacement,
                slip_state: e.slip_state,
                applied: e.applied,
                inputs: e.inputs,
                parameters: e.parameters,
                last_iterations: e.last_iterations,
                wrinkle: e.wrinkle,
                tension_angle: e.tension_angle,
                plastic: Vec::new(),
            },
            time: l.time,
            last_successful_time: l.last_successful_time,
            wants_to_terminate: l.wants_to_terminate,
            fsm: l.fsm,
            experiment: l.experiment,
        }
        .into()
    }
}

/// The payload of format version 5: [`Snapshot`] whose engine state ends before the
/// velocities and accelerations.
#[derive(Deserialize)]
struct Legacy5 {
    engine: Engine5,
    time: f64,
    last_successful_time: f64,
    wants_to_terminate: bool,
    fsm: FsmState,
    experiment: Experiment,
}

/// [`EngineState`] of format version 5.
#[derive(Deserialize)]
struct Engine5 {
    displacement: Vec<f64>,
    slip_state: Vec<crate::model::sleeve::Contact>,
    applied: Vec<f64>,
    inputs: Vec<f64>,
    parameters: Vec<f64>,
    last_iterations: u32,
    wrinkle: Vec<crate::model::wrinkling::WrinkleState>,
    tension_angle: Vec<f64>,
    plastic: Vec<f64>,
}

impl From<Legacy5> for Snapshot {
    fn from(l: Legacy5) -> Snapshot {
        let e = l.engine;
        Snapshot {
            engine: EngineState {
                displacement: e.displacement,
                slip_state: e.slip_state,
                applied: e.applied,
                inputs: e.inputs,
                parameters: e.parameters,
                last_iterations: e.last_iterations,
                wrinkle: e.wrinkle,
                tension_angle: e.tension_angle,
                plastic: e.plastic,
                velocity: Vec::new(),
                acceleration: Vec::new(),
            },
            time: l.time,
            last_successful_time: l.last_successful_time,
            wants_to_terminate: l.wants_to_terminate,
            fsm: l.fsm,
            experiment: l.experiment,
        }
    }
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
pub fn encode(snapshot: &Snapshot, guid: &str) -> Result<Vec<u8>, Error> {
    let payload = postcard::to_allocvec(snapshot)
        .map_err(|e| Error::Internal(format!("the state could not be encoded: {e}")))?;
    let guid_len = u32::try_from(guid.len())
        .map_err(|_| Error::Internal("the GUID is too long to encode a state".into()))?;
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

/// Read bytes written by [`encode`]; `guid` is the reading instance's GUID. Returns the
/// snapshot and the format version it was written in (a version 3 state comes back as written:
/// see [`upgrade`]). Err: [`Error::StateBytes`] naming the first check that failed.
pub fn decode(bytes: &[u8], guid: &str) -> Result<(Snapshot, u32), Error> {
    let failed = |check: &'static str, why: String| Error::StateBytes { check, why };
    let mut r = Reader { bytes, at: 0 };
    if r.take(8, "magic")? != STATE_MAGIC {
        return Err(failed(
            "magic",
            "the bytes are not a Velarium FMU state".into(),
        ));
    }
    let version = r.u32("format version")?;
    if !(OLDEST_STATE_FORMAT_VERSION..=STATE_FORMAT_VERSION).contains(&version) {
        return Err(failed(
            "version",
            format!("format version {version}, this FMU reads {OLDEST_STATE_FORMAT_VERSION} to {STATE_FORMAT_VERSION}"),
        ));
    }
    let guid_len = r.u32("GUID length")? as usize;
    let saved_guid = r.take(guid_len, "GUID")?;
    let payload_len = r.u64("payload length")?;
    let expected = (r.at as u64)
        .checked_add(payload_len)
        .and_then(|n| n.checked_add(8));
    if expected != Some(bytes.len() as u64) {
        return Err(failed(
            "length",
            format!(
                "the header announces {} bytes, {} were given (truncated or extended)",
                expected.map_or("too many".to_string(), |n| n.to_string()),
                bytes.len()
            ),
        ));
    }
    let body_end = bytes.len() - 8;
    let checksum = u64::from_le_bytes(bytes[body_end..].try_into().expect("8 bytes"));
    if fnv1a64(&bytes[..body_end]) != checksum {
        return Err(failed("checksum", "the bytes are corrupted".into()));
    }
    if saved_guid != guid.as_bytes() {
        return Err(failed(
            "GUID",
            format!(
                "the state belongs to GUID {}, this instance has GUID {guid}",
                String::from_utf8_lossy(saved_guid)
            ),
        ));
    }
    let payload = &bytes[r.at..body_end];
    let (snapshot, rest) = if version >= 6 {
        postcard::take_from_bytes::<Snapshot>(payload)
    } else if version == 5 {
        postcard::take_from_bytes::<Legacy5>(payload).map(|(l, rest)| (l.into(), rest))
    } else {
        postcard::take_from_bytes::<Legacy>(payload).map(|(l, rest)| (l.into(), rest))
    }
    .map_err(|e| failed("payload", e.to_string()))?;
    if !rest.is_empty() {
        return Err(failed(
            "payload",
            format!("{} bytes left over after the state", rest.len()),
        ));
    }
    Ok((snapshot, version))
}

/// A snapshot read from format `version` in the current format, for a model whose unknown
/// vector has `unknowns` entries, `multipliers` of them the sleeve ties' multipliers (3 per
/// tie, last): a version 3 state whose unknown vector ends where they begin gets them, 0.
/// Anything else is left as it is (a state of another model is refused by its sizes).
pub fn upgrade(snapshot: &mut Snapshot, version: u32, unknowns: usize, multipliers: usize) {
    let u = &mut snapshot.engine.displacement;
    if version == 3 && multipliers > 0 && u.len() + multipliers == unknowns {
        u.resize(unknowns, 0.0);
    }
}

/// A cursor that names the field it could not read.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, field: &str) -> Result<&'a [u8], Error> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or_else(|| Error::StateBytes {
            check: "length",
            why: format!(
                "the bytes end inside the {field} ({} bytes given)",
                self.bytes.len()
            ),
        })?;
        let slice = &self.bytes[self.at..end];
        self.at = end;
        Ok(slice)
    }

    fn u32(&mut self, field: &str) -> Result<u32, Error> {
        Ok(u32::from_le_bytes(
            self.take(4, field)?.try_into().expect("4 bytes"),
        ))
    }

    fn u64(&mut self, field: &str) -> Result<u64, Error> {
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
        let (back, _) = decode(&bytes, "{abc}").unwrap();
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
            let e = decode(b, guid).unwrap_err().to_string();
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

    // GOAL: the wrinkle and stick/slip states travel as their codes (the variant index: taut 0,
    //       wrinkled 1, slack 2; stick 0, forward 1, backward 2, merged 3), and a state whose
    //       code is none of them is refused by the payload check: the engine only ever holds
    //       typed states. REFERENCE: the codes above, compared exactly.
    #[test]
    fn state_codes_are_checked_at_the_boundary() {
        use crate::model::sleeve::Contact;
        use crate::model::wrinkling::WrinkleState;
        // The byte of the first entry of a vector: where two payloads differing only there
        // differ.
        let at = |a: &Snapshot, b: &Snapshot| {
            let (pa, pb) = (
                payload(&encode(a, "{abc}").unwrap(), "{abc}"),
                payload(&encode(b, "{abc}").unwrap(), "{abc}"),
            );
            assert_eq!(pa.len(), pb.len());
            let i = (0..pa.len()).find(|&i| pa[i] != pb[i]).unwrap();
            (i, pa, pb)
        };
        let mut base = sample();
        base.engine.wrinkle = vec![WrinkleState::Taut];
        base.engine.slip_state = vec![Contact::Stick];
        let mut slack = base.clone();
        slack.engine.wrinkle[0] = WrinkleState::Slack;
        let (w, _, p) = at(&base, &slack);
        assert_eq!(p[w], 2, "slack is code 2");
        let mut backward = base.clone();
        backward.engine.slip_state[0] = Contact::Backward;
        let (c, _, p) = at(&base, &backward);
        assert_eq!(p[c], 2, "backward is code 2");
        let mut merged = base.clone();
        merged.engine.slip_state[0] = Contact::Merged;
        assert_eq!(at(&base, &merged).2[c], 3, "merged is code 3");
        let good = payload(&encode(&base, "{abc}").unwrap(), "{abc}");
        for (index, codes) in [(w, [3u8, 7, 127]), (c, [4, 7, 127])] {
            for code in codes {
                let mut bad = good.clone();
                bad[index] = code;
                let e = decode(&seal(STATE_FORMAT_VERSION, "{abc}", &bad), "{abc}").unwrap_err();
                assert!(
                    e.to_string().contains("payload check failed"),
                    "code {code}: {e}"
                );
            }
        }
    }

    /// The special f64 values whose bits must survive: NaNs with payloads (quiet, signalling,
    /// negative), ±Inf, -0, the smallest subnormal, the largest finite, and 0.1 + 0.2.
    const SPECIAL: [u64; 9] = [
        0x7ff8_0000_dead_beef,
        0x7ff0_0000_0000_0001,
        0xfff8_0000_0000_0007,
        0x7ff0_0000_0000_0000,
        0xfff0_0000_0000_0000,
        0x8000_0000_0000_0000,
        0x0000_0000_0000_0001,
        0x7fef_ffff_ffff_ffff,
        0x3fd3_3333_3333_3334,
    ];

    /// A container sealed as `encode` seals one, around any payload and with any version, so
    /// that the payload decoder itself is reached.
    fn seal(version: u32, guid: &str, payload: &[u8]) -> Vec<u8> {
        let mut out = STATE_MAGIC.to_vec();
        out.extend_from_slice(&version.to_le_bytes());
        out.extend_from_slice(&(guid.len() as u32).to_le_bytes());
        out.extend_from_slice(guid.as_bytes());
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        out.extend_from_slice(payload);
        let sum = fnv1a64(&out);
        out.extend_from_slice(&sum.to_le_bytes());
        out
    }

    /// The payload of bytes written by `encode`.
    fn payload(bytes: &[u8], guid: &str) -> Vec<u8> {
        bytes[24 + guid.len()..bytes.len() - 8].to_vec()
    }

    // GOAL: f64 values come back bit for bit, NaN payloads and ±Inf included, wherever they
    //       sit (vectors, plain fields, options). REFERENCE: IEEE 754 bits; comparison: equality
    //       of the bits.
    #[test]
    fn f64_bits_come_back_exactly() {
        let f = f64::from_bits;
        let mut s = sample();
        assert_eq!(s.engine.displacement.len(), SPECIAL.len());
        s.engine.displacement = SPECIAL.map(f).to_vec();
        s.engine.applied = vec![f(SPECIAL[1])];
        s.time = f(SPECIAL[0]);
        s.last_successful_time = f(SPECIAL[4]);
        s.experiment.tolerance = Some(f(SPECIAL[2]));
        s.experiment.stop_time = Some(f(SPECIAL[3]));
        let (back, _) = decode(&encode(&s, "{abc}").unwrap(), "{abc}").unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back.engine.displacement), SPECIAL);
        assert_eq!(bits(&back.engine.applied), [SPECIAL[1]]);
        assert_eq!(back.time.to_bits(), SPECIAL[0]);
        assert_eq!(back.last_successful_time.to_bits(), SPECIAL[4]);
        assert_eq!(
            back.experiment.tolerance.map(f64::to_bits),
            Some(SPECIAL[2])
        );
        assert_eq!(
            back.experiment.stop_time.map(f64::to_bits),
            Some(SPECIAL[3])
        );
    }

    // GOAL: the output is deterministic: the same state encodes to the same bytes, and bytes
    //       decoded and encoded again are unchanged. Comparison: byte equality.
    #[test]
    fn encoding_is_deterministic() {
        let bytes = encode(&sample(), "{abc}").unwrap();
        assert_eq!(encode(&sample(), "{abc}").unwrap(), bytes);
        let (back, _) = decode(&bytes, "{abc}").unwrap();
        assert_eq!(encode(&back, "{abc}").unwrap(), bytes);
    }

    // GOAL: a state of another format version (version 2: the fixed-width payload, 8-byte
    //       lengths) is refused by the version check before its payload is read.
    #[test]
    fn another_format_version_is_refused() {
        let bytes = encode(&sample(), "{abc}").unwrap();
        for version in [0, 1, 2, 7, u32::MAX] {
            let e = decode(&seal(version, "{abc}", &payload(&bytes, "{abc}")), "{abc}")
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(&format!(
                    "version check failed: format version {version}, this FMU reads 3 to 6"
                )),
                "{e}"
            );
        }
    }

    // GOAL: a version 3 state (the payload of 4 without the tie multipliers) is read, and
    //       [`upgrade`] appends the multipliers, 0, only where the unknown vector ends where
    //       they begin; a version 4 state and a vector of another length are left as they are.
    #[test]
    fn a_version_3_state_is_read_and_gets_zero_multipliers() {
        let mut snapshot = sample();
        // Comparable with ==: no NaN.
        snapshot.engine.displacement[4] = 0.5;
        let old = seal(3, "{abc}", &legacy_payload(&snapshot));
        let (mut back, version) = decode(&old, "{abc}").unwrap();
        assert_eq!((version, &back), (3, &snapshot));
        let n = snapshot.engine.displacement.len();
        upgrade(&mut back, 4, n + 6, 6);
        assert_eq!(back.engine.displacement.len(), n, "version 4: unchanged");
        upgrade(&mut back, 3, n + 7, 6);
        assert_eq!(
            back.engine.displacement.len(),
            n,
            "another model: unchanged"
        );
        upgrade(&mut back, 3, n + 6, 6);
        assert_eq!(
            back.engine.displacement[..n],
            snapshot.engine.displacement[..n]
        );
        assert_eq!(back.engine.displacement[n..], [0.0; 6]);
    }

    // GOAL: hostile payloads behind a valid header and checksum (what a fuzzer that reseals
    //       the checksum reaches) are errors naming the payload check, never a panic: every
    //       truncation, trailing bytes, a length prefix of u64::MAX, of 2^40 and an over-long
    //       varint, a wrong enum tag, bool and Option tags of 2; and every bit flip and every
    //       byte set to 0x00, 0x7f, 0x80 or 0xff decodes to an error or a value (the values are
    //       checked after decoding, `Instance::check_snapshot`). Comparison: the error's text.
    #[test]
    fn hostile_payloads_are_errors_not_panics() {
        let guid = "{abc}";
        let good = payload(&encode(&sample(), guid).unwrap(), guid);
        let payload_error = |p: &[u8]| {
            let e = decode(&seal(STATE_FORMAT_VERSION, guid, p), guid)
                .unwrap_err()
                .to_string();
            assert!(e.starts_with("payload check failed: "), "{e}");
            e
        };
        for cut in 0..good.len() {
            payload_error(&good[..cut]);
        }
        for tail in [&[0u8][..], &[0xff; 16]] {
            let e = payload_error(&[&good[..], tail].concat());
            assert!(e.contains("left over"), "{e}");
        }
        // The payload opens with the displacement's length, 9 here: one varint byte.
        assert_eq!(good[0], 9);
        let mut varint_max = vec![0xff; 9];
        varint_max.push(0x01);
        let two_to_40 = [0x80, 0x80, 0x80, 0x80, 0x80, 0x20];
        let over_long = [0xff; 11];
        for length in [&varint_max[..], &two_to_40, &over_long] {
            payload_error(&[length, &good[1..]].concat());
        }
        // The tail: wants_to_terminate, fsm, done, tolerance None, start_time, stop_time Some.
        let n = good.len();
        assert_eq!(good[n - 20..n - 17], [FsmState::StepComplete as u8, 1, 0]);
        for (at, byte) in [
            (n - 20, 6),
            (n - 20, 0xff),
            (n - 21, 2),
            (n - 19, 2),
            (n - 18, 2),
        ] {
            let mut bad = good.clone();
            bad[at] = byte;
            payload_error(&bad);
        }
        for at in 0..n {
            let flips = (0..8).map(|bit| good[at] ^ (1 << bit));
            for byte in flips.chain([0x00, 0x7f, 0x80, 0xff]) {
                let mut bad = good.clone();
                bad[at] = byte;
                let _ = decode(&seal(STATE_FORMAT_VERSION, guid, &bad), guid);
            }
        }
    }

    /// The payload of formats 3 and 4 for a snapshot without plastic strains: format 6's less
    /// the empty `plastic`, `velocity` and `acceleration` (varint lengths 0, the engine
    /// state's last 3 bytes).
    fn legacy_payload(snapshot: &Snapshot) -> Vec<u8> {
        assert!(snapshot.engine.plastic.is_empty());
        drop_engine_tail(snapshot, 3)
    }

    /// Format 6's payload less the engine state's last `k` bytes (empty vectors' lengths).
    fn drop_engine_tail(snapshot: &Snapshot, k: usize) -> Vec<u8> {
        assert!(snapshot.engine.velocity.is_empty() && snapshot.engine.acceleration.is_empty());
        let body = postcard::to_allocvec(snapshot).unwrap();
        let engine_len = postcard::to_allocvec(&snapshot.engine).unwrap().len();
        assert!(body[engine_len - k..engine_len].iter().all(|b| *b == 0));
        [&body[..engine_len - k], &body[engine_len..]].concat()
    }

    // GOAL: the plastic strains of an elastoplastic model travel bit for bit (format 5), and a
    // state written in format 4 (the same payload without them) is still read, with none.
    #[test]
    fn plastic_strains_round_trip_and_format_4_is_read() {
        let guid = "{abc}";
        let mut with = sample();
        // Comparable with ==: no NaN.
        with.engine.displacement[4] = 0.5;
        with.engine.plastic = vec![0.1 + 0.2, -1e-300, 2.5e-2, f64::MIN_POSITIVE];
        let (back, version) = decode(&encode(&with, guid).unwrap(), guid).unwrap();
        assert_eq!(version, STATE_FORMAT_VERSION);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back.engine.plastic), bits(&with.engine.plastic));
        assert_eq!(back, with);
        // Format 4: the engine state ends before `plastic`.
        let mut plain = sample();
        plain.engine.displacement[4] = 0.5;
        let old = legacy_payload(&plain);
        let (back, version) = decode(&seal(4, guid, &old), guid).unwrap();
        assert_eq!(version, 4);
        assert_eq!(back, plain);
        // The format 4 layout is refused as format 5 (a byte short).
        assert!(decode(&seal(5, guid, &old), guid).is_err());
        // Format 5: the engine state ends before `velocity` and `acceleration`; the plastic
        // strains come back, the motion empty.
        let five = drop_engine_tail(&with, 2);
        let (back, version) = decode(&seal(5, guid, &five), guid).unwrap();
        assert_eq!(version, 5);
        assert_eq!(back, with);
        assert!(decode(&seal(6, guid, &five), guid).is_err());
    }

    // GOAL: a dynamic scene's velocities and accelerations travel bit for bit (format 6).
    #[test]
    fn motion_round_trips() {
        let guid = "{abc}";
        let mut with = sample();
        // Comparable with ==: no NaN.
        with.engine.displacement[4] = 0.5;
        with.engine.velocity = vec![0.1 + 0.2, -1e-300, 2.5e-2];
        with.engine.acceleration = vec![-3.0, f64::MIN_POSITIVE, 1e30];
        let (back, version) = decode(&encode(&with, guid).unwrap(), guid).unwrap();
        assert_eq!(version, 6);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back.engine.velocity), bits(&with.engine.velocity));
        assert_eq!(
            bits(&back.engine.acceleration),
            bits(&with.engine.acceleration)
        );
        assert_eq!(back, with);
    }
}
