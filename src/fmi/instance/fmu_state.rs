//! FMU states of an instance: take a [`Snapshot`], restore one, and move it through the checked
//! byte form of `snapshot.rs`. The handles themselves are managed by the C shims (`ffi.rs`); the
//! methods here receive closures that store or release them.

use super::Instance;
use crate::fmi::fsm::{FsmState, Func};
use crate::fmi::snapshot::{self, Snapshot};
use crate::fmi::Status;

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

    /// `fmi2GetFMUstate`: `store` puts the snapshot where the master's handle points.
    pub fn get_fmu_state(&mut self, store: impl FnOnce(Snapshot) -> Result<(), String>) -> Status {
        self.call(Func::GetFmuState, String::new(), |s| {
            store(s.snapshot())?;
            Ok(Status::Ok)
        })
    }

    /// `fmi2SetFMUstate`: continue exactly from the snapshot (also into a fresh instance).
    pub fn set_fmu_state(&mut self, snapshot: Result<&Snapshot, String>) -> Status {
        self.call(Func::SetFmuState, String::new(), |s| {
            let snapshot = snapshot?;
            s.heal()?;
            s.engine
                .set_state(snapshot.engine.clone())
                .map_err(|e| e.to_string())?;
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

    /// `fmi2FreeFMUstate`: `release` frees the master's handle.
    pub fn free_fmu_state(&mut self, release: impl FnOnce() -> Result<(), String>) -> Status {
        self.call(Func::FreeFmuState, String::new(), |_| {
            release().map(|_| Status::Ok)
        })
    }

    pub fn serialized_fmu_state_size(
        &mut self,
        snapshot: Result<&Snapshot, String>,
        store: impl FnOnce(usize) -> Result<(), String>,
    ) -> Status {
        self.call(Func::SerializedFmuStateSize, String::new(), |s| {
            store(snapshot::encode(snapshot?, &s.guid)?.len())?;
            Ok(Status::Ok)
        })
    }

    pub fn serialize_fmu_state(
        &mut self,
        snapshot: Result<&Snapshot, String>,
        buffer: Result<&mut [u8], String>,
    ) -> Status {
        self.call(Func::SerializeFmuState, String::new(), |s| {
            let bytes = snapshot::encode(snapshot?, &s.guid)?;
            let buffer = buffer?;
            if buffer.len() < bytes.len() {
                return Err(format!(
                    "the buffer holds {} bytes, the state needs {} (see fmi2SerializedFMUstateSize)",
                    buffer.len(),
                    bytes.len()
                ));
            }
            buffer[..bytes.len()].copy_from_slice(&bytes);
            Ok(Status::Ok)
        })
    }

    /// `fmi2DeSerializeFMUstate`: check the bytes (see `snapshot.rs`), then `store` a new state.
    pub fn deserialize_fmu_state(
        &mut self,
        bytes: Result<&[u8], String>,
        store: impl FnOnce(Snapshot) -> Result<(), String>,
    ) -> Status {
        let args = self.args(|| format!("size={}", bytes.as_ref().map_or(0, |b| b.len())));
        self.call(Func::DeSerializeFmuState, args, |s| {
            let snapshot = snapshot::decode(bytes?, &s.guid)?;
            store(snapshot)?;
            Ok(Status::Ok)
        })
    }
}
