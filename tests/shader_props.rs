//! Shader property tests (in progress).
