//! splatphys_ipc (work in progress).
