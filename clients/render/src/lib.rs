//! splatphys-render (work in progress).
