//! Tests of the BVH walk.
