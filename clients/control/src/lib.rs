//! splatphys-control (work in progress).
