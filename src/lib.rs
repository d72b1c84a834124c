//! raylume
