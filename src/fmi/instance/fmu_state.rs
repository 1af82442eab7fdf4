//! FMU states of an instance: take a [`Snapshot`], restore one, and move it through the checked
//! byte form of `snapshot.rs`. The handles themselves are managed by the C shims (`ffi.rs`); the
//! methods here receive closures that store or release them.

use super::Instance;
use crate::error::Error;
use crate::fmi::fmi2_ffi::Status;
use crate::fmi::fsm::{FsmState, Func};
use crate::fmi::snapshot::{self, Snapshot};

impl Instance {
    /// The instance's state as plain data.
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            engine: self.engine.state().clone(),
            time: self.time,
            last_successful_time: self.last_successful_time,
            wants_to_terminate: self.wants_to_terminate,
            fsm: self.fsm,
            experiment: self.experiment,
        }
    }

    /// Make sure `copies` copies of a state of `bytes` bytes can be had before one is made
    /// (`crate::memory::probe`): a state as large as the model is copied, encoded and decoded
    /// here, outside any step.
    fn probe_state(bytes: u64, copies: u64) -> Result<(), Error> {
        Ok(crate::memory::probe(
            bytes.saturating_mul(copies),
            "copies of the FMU state",
        )?)
    }

    /// `fmi2GetFMUstate`: `store` puts the snapshot where the master's handle points.
    pub fn get_fmu_state(&mut self, store: impl FnOnce(Snapshot) -> Result<(), Error>) -> Status {
        self.call(Func::GetFmuState, String::new(), |s| {
            Self::probe_state(s.engine.state().bytes(), 1)?;
            store(s.snapshot())?;
            Ok(Status::Ok)
        })
    }

    /// `fmi2SetFMUstate`: continue exactly from the snapshot (also into a fresh instance).
    pub fn set_fmu_state(&mut self, snapshot: Result<&Snapshot, Error>) -> Status {
        self.call(Func::SetFmuState, String::new(), |s| {
            let snapshot = snapshot?;
            s.check_snapshot(snapshot)?;
            // The engine's copy, the initialization base, and the state they replace.
            Self::probe_state(snapshot.engine.bytes(), 3)?;
            s.heal()?;
            let engine_state = snapshot.engine.clone();
            s.on_worker(|engine| engine.set_state(engine_state))?;
            s.time = snapshot.time;
            s.last_successful_time = snapshot.last_successful_time;
            s.wants_to_terminate = snapshot.wants_to_terminate;
            s.fsm = snapshot.fsm;
            s.experiment = snapshot.experiment;
            s.init_base = (s.fsm == FsmState::InitializationMode).then(|| snapshot.engine.clone());
            s.init_solved = false;
            Ok(Status::Ok)
        })
    }

    /// The values of a snapshot, before anything is changed: the engine's state (finite
    /// displacements, valid codes, inputs and parameters in range), finite times and a sound
    /// experiment. The first failed check is named.
    fn check_snapshot(&self, snapshot: &Snapshot) -> Result<(), Error> {
        self.engine.check_state(&snapshot.engine)?;
        for (field, t) in [
            ("time", snapshot.time),
            ("last_successful_time", snapshot.last_successful_time),
            ("experiment.start_time", snapshot.experiment.start_time),
        ] {
            if !t.is_finite() {
                return Err(Error::State(format!("{field} = {t} is not finite")));
            }
        }
        let e = &snapshot.experiment;
        if e.stop_time
            .is_some_and(|stop| !(stop.is_finite() && stop >= e.start_time))
            || e.tolerance
                .is_some_and(|tol| !(tol.is_finite() && tol > 0.0))
        {
            return Err(Error::State(format!(
                "experiment (startTime {}, stopTime {:?}, tolerance {:?}) is not a valid experiment",
                e.start_time, e.stop_time, e.tolerance
            )));
        }
        Ok(())
    }

    /// `fmi2FreeFMUstate`: `release` frees the master's handle.
    pub fn free_fmu_state(&mut self, release: impl FnOnce() -> Result<(), Error>) -> Status {
        self.call(Func::FreeFmuState, String::new(), |_| {
            release().map(|_| Status::Ok)
        })
    }

    pub fn serialized_fmu_state_size(
        &mut self,
        snapshot: Result<&Snapshot, Error>,
        store: impl FnOnce(usize) -> Result<(), Error>,
    ) -> Status {
        self.call(Func::SerializedFmuStateSize, String::new(), |s| {
            let snapshot = snapshot?;
            // The encoder's buffer grows by doubling: at most twice the encoded size.
            Self::probe_state(snapshot.engine.bytes(), 2)?;
            store(snapshot::encode(snapshot, &s.guid)?.len())?;
            Ok(Status::Ok)
        })
    }

    pub fn serialize_fmu_state(
        &mut self,
        snapshot: Result<&Snapshot, Error>,
        buffer: Result<&mut [u8], Error>,
    ) -> Status {
        self.call(Func::SerializeFmuState, String::new(), |s| {
            let snapshot = snapshot?;
            Self::probe_state(snapshot.engine.bytes(), 2)?;
            let bytes = snapshot::encode(snapshot, &s.guid)?;
            let buffer = buffer?;
            if buffer.len() < bytes.len() {
                return Err(Error::Argument {
                    argument: "size",
                    message: format!(
                        "the buffer holds {} bytes, the state needs {} (see fmi2SerializedFMUstateSize)",
                        buffer.len(),
                        bytes.len()
                    ),
                });
            }
            buffer[..bytes.len()].copy_from_slice(&bytes);
            Ok(Status::Ok)
        })
    }

    /// `fmi2DeSerializeFMUstate`: check the bytes (see `snapshot.rs`; a version 3 state gets
    /// the sleeve ties' multipliers, 0), then `store` a new state.
    pub fn deserialize_fmu_state(
        &mut self,
        bytes: Result<&[u8], Error>,
        store: impl FnOnce(Snapshot) -> Result<(), Error>,
    ) -> Status {
        let args = self.args(|| format!("size={}", bytes.as_ref().map_or(0, |b| b.len())));
        self.call(Func::DeSerializeFmuState, args, |s| {
            let bytes = bytes?;
            // The decoded vectors take about the bytes' size, grown by doubling.
            Self::probe_state(bytes.len() as u64, 2)?;
            let (mut snapshot, version) = snapshot::decode(bytes, &s.guid)?;
            let model = s.engine.model();
            snapshot::upgrade(
                &mut snapshot,
                version,
                model.unknown_count(),
                3 * model.ties.len(),
            );
            store(snapshot)?;
            Ok(Status::Ok)
        })
    }
}
