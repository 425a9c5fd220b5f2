//! splatphys-record (work in progress).
