//! Tests of the BVH build (`bvh.rs`): placeholder replaced below.
