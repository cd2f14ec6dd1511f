//! Tests of the packet walks against the single-ray walks.
