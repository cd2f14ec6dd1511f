"""The scene of ci/peers/equal-work.toml as a Mitsuba 3 scene dictionary, shared by the CPU
comparison (ci/mitsuba/equal-work.py, `scalar_rgb`) and the GPU one (mitsuba_equal_work.py,
`cuda_ad_rgb`) so the two cannot drift apart: the Stanford bunny (flat-shaded, as fragtrace
shades an OBJ without normals) on a 4x4 diffuse floor at y = 0.0335, one point light, the
`direct` integrator with one emitter sample and no BSDF sample (a primary ray and one shadow
ray per hit: fragtrace's `max_depth = 0`), 1 sample per pixel."""


def scene(mi, size, obj):
    """The scene dictionary at size x size pixels with the bunny OBJ at `obj`; `mi` is the
    mitsuba module with its variant set."""
    T = mi.ScalarTransform4f
    return {
        "type": "scene",
        "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
        "sensor": {
            "type": "perspective",
            "fov": 32.0,
            "fov_axis": "y",
            "to_world": T().look_at(origin=[-0.2, 0.17, 0.36], target=[-0.015, 0.1, 0.0], up=[0, 1, 0]),
            "sampler": {"type": "independent", "sample_count": 1},
            "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"}},
        },
        "light": {"type": "point", "position": [-0.6, 1.2, 0.9], "intensity": {"type": "rgb", "value": 0.85}},
        "bunny": {
            "type": "obj",
            "filename": obj,
            "face_normals": True,
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.77, 0.74, 0.68]}},
        },
        "floor": {
            "type": "rectangle",
            # Mitsuba's rectangle is [-1, 1]^2 in z = 0: scaled by 2 and turned into y = 0.0335.
            "to_world": T().translate([0.0, 0.0335, 0.0]) @ T().rotate([1, 0, 0], -90) @ T().scale(2.0),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.4, 0.4, 0.4]}},
        },
    }
