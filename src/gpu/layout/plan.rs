//! What the layout will allocate ([`LayoutPlan`]): every texture's texels counted from the
//! scene's and the grid's sizes, and checked against the GPU's texture size and the host's
//! memory before any texture is allocated (issue 53: a scene too large is refused in one
//! line, not after allocating it). The counts matter most for the irregular grid: its cells
//! sit at float slots ([`float_slot`](super::float_slot)) that get sparser every 2^23 cells past 2^24, so its
//! cell texture grows faster than its cells: the 100-sphere scene's 61.5 M cells take
//! 2.14 G texels (34 GB), where they would take 184 M densely. The compute kernel's dense
//! layout of the irregular grid ([`GridCounts::Dense`]) is counted as storage buffers of
//! bytes instead: 32 bytes per cell, 4 per reference and per voxel-map entry, checked
//! against GL_MAX_SHADER_STORAGE_BLOCK_SIZE ([`DenseIrregular::check`](super::DenseIrregular::check))
//! and, with the textures, against the host's memory.

use super::packed::too_large;
use super::tex::TexLayout;
use super::{
    irregular_cell_texels, texture_dims, DenseBuffer, IndexFormat, LIST_PER_TEXEL, MAT_TEXELS,
    TRI_TEXELS,
};
use crate::scene::Scene;
use crate::{Error, Result};

/// Bytes of one RGBA32F texel.
pub const TEXEL_BYTES: u64 = std::mem::size_of::<[f32; 4]>() as u64;

/// What the grid adds to the layout, in counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridCounts {
    /// A uniform grid: its cells and triangle references.
    Uniform {
        /// Cells.
        cells: u64,
        /// Triangle references.
        refs: u64,
    },
    /// An irregular grid: its cells, references and the voxel map as the GPU reads it.
    Irregular {
        /// Cells.
        cells: u64,
        /// Triangle references.
        refs: u64,
        /// Voxel-map entries as laid out for the GPU (hops, aligned blocks).
        vmap_entries: u64,
    },
    /// An irregular grid in the compute kernel's integer buffers ([`DenseIrregular`](super::DenseIrregular)).
    Dense {
        /// Cells.
        cells: u64,
        /// Triangle references.
        refs: u64,
        /// Voxel-map entries.
        vmap_entries: u64,
    },
}

/// The counts the layout's texture sizes follow from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LayoutCounts {
    /// Triangles.
    pub triangles: u64,
    /// Whether the vertex-normal texture is packed.
    pub normals: bool,
    /// Materials.
    pub materials: u64,
    /// The grid.
    pub grid: GridCounts,
    /// Texels of the `tex` texture (`None`: the scene has none).
    pub tex_texels: Option<u64>,
    /// Texels of an instanced scene's instancing data `inst` (`contract::instancing`).
    pub inst_texels: Option<u64>,
    /// The index format the textures are written in.
    pub format: IndexFormat,
}

impl LayoutCounts {
    /// The counts of `scene` over `grid` (the vertex-normal texture when `normals`).
    pub fn of(scene: &Scene, grid: GridCounts, normals: bool, format: IndexFormat) -> Self {
        LayoutCounts {
            triangles: scene.triangles.len() as u64,
            normals,
            materials: scene.materials.len() as u64,
            grid,
            tex_texels: TexLayout::texels(scene),
            inst_texels: None,
            format,
        }
    }
}

/// Every texture the layout allocates, with its texels, in packing order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LayoutPlan {
    /// (texture name, texels).
    pub textures: Vec<(&'static str, u64)>,
    /// (storage buffer name, bytes): the dense grid's.
    pub buffers: Vec<(&'static str, u64)>,
    /// Whether the grid is the irregular one (what the refusals advise).
    pub irregular: bool,
}

impl LayoutPlan {
    /// The textures `c` takes.
    pub fn new(c: &LayoutCounts) -> Self {
        let tri = c.triangles * TRI_TEXELS as u64;
        let mut textures = vec![("tri", tri)];
        if c.normals {
            textures.push(("nrm", tri));
        }
        textures.push(("mat", c.materials * MAT_TEXELS as u64));
        let entries = |n: u64| n.div_ceil(LIST_PER_TEXEL as u64);
        let mut buffers = Vec::new();
        let irregular = match c.grid {
            GridCounts::Uniform { cells, refs } => {
                textures.push(("cell", cells));
                textures.push(("list", entries(refs)));
                false
            }
            GridCounts::Irregular {
                cells,
                refs,
                vmap_entries,
            } => {
                textures.push(("cell", irregular_cell_texels(cells, c.format)));
                textures.push(("list", entries(refs)));
                textures.push(("vmap", entries(vmap_entries)));
                true
            }
            GridCounts::Dense {
                cells,
                refs,
                vmap_entries,
            } => {
                for b in DenseBuffer::ALL {
                    let n = b.elements(cells, refs, vmap_entries);
                    buffers.push((b.name(), n * b.element_bytes()));
                }
                true
            }
        };
        if let Some(t) = c.tex_texels {
            textures.push(("tex", t));
        }
        if let Some(t) = c.inst_texels {
            textures.push(("inst", t));
        }
        LayoutPlan {
            textures,
            buffers,
            irregular,
        }
    }

    /// Host bytes of the textures as packed under a limit of `max_size` (rows padded) and
    /// of the dense grid's buffers.
    pub fn bytes(&self, max_size: u32) -> u64 {
        self.textures
            .iter()
            .map(|&(_, n)| {
                let (w, h) = texture_dims(n, max_size);
                w as u64 * h * TEXEL_BYTES
            })
            .sum::<u64>()
            + self.buffers.iter().map(|&(_, b)| b).sum::<u64>()
    }

    /// Options that render the scene when texture `name` cannot be packed: every structure
    /// stores the triangles, materials and textures; the other grid, or the CPU, may fit
    /// where a grid's own textures do not.
    fn advice(&self, name: &str) -> &'static str {
        match (name, self.irregular) {
            ("cell" | "list" | "vmap", true) => "--accel uniform, or --backend cpu",
            (n, true) if n.starts_with("dense_") => "--accel uniform, or --backend cpu",
            ("cell" | "list", false) => "a lower --grid-density, or --backend cpu",
            _ => "--backend cpu",
        }
    }

    /// Refuses, in one line naming the need, the limit and options that exist, a layout
    /// with a texture wider or higher than `max_size` (GL_MAX_TEXTURE_SIZE), or whose
    /// textures, with the driver's copy of them, need more host memory than `available`
    /// bytes (`None`: not known, not checked). Reads counts only: call it before packing.
    pub fn check(&self, max_size: u32, available: Option<u64>) -> Result<()> {
        for &(name, n) in &self.textures {
            if texture_dims(n, max_size).1 > max_size as u64 {
                return Err(too_large(name, n, max_size, self.advice(name)));
            }
        }
        let Some(available) = available else {
            return Ok(());
        };
        // The textures on the host, and the driver's copy (llvmpipe keeps it in host
        // memory; a discrete GPU's driver stages its uploads there).
        let bytes = self.bytes(max_size);
        let need = 2 * bytes;
        if need <= available {
            return Ok(());
        }
        let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
        let (name, n) = self
            .textures
            .iter()
            .copied()
            .max_by_key(|&(_, n)| n)
            .unwrap_or(("tri", 0));
        let (name, what, largest) = match self.buffers.iter().copied().max_by_key(|&(_, b)| b) {
            Some((b, bytes)) if bytes > self.bytes_of(name, max_size) => {
                (b, format!("{bytes} bytes"), bytes)
            }
            _ => (name, format!("{n} texels"), self.bytes_of(name, max_size)),
        };
        Err(Error::Limit(format!(
            "the GPU layout of the {} grid needs about {:.1} GiB of host memory (its textures \
             and buffers, {:.1} GiB, the largest `{name}` of {what} at {:.1} GiB, and the \
             driver's copy), and {:.1} GiB is available; render it with {}",
            if self.irregular {
                "irregular"
            } else {
                "uniform"
            },
            gib(need),
            gib(bytes),
            gib(largest),
            gib(available),
            self.advice(name),
        )))
    }

    /// Host bytes of texture `name` as packed under `max_size` (0 when not in the plan).
    pub fn bytes_of(&self, name: &str, max_size: u32) -> u64 {
        self.textures
            .iter()
            .filter(|&&(n, _)| n == name)
            .map(|&(_, t)| {
                let (w, h) = texture_dims(t, max_size);
                w as u64 * h * TEXEL_BYTES
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 100-sphere scene's counts (32.8 M triangles, 61.5 M irregular cells, from the
    /// H100's refusal: 2144492355 cell texels) on a GPU of 32768-texel textures: refused
    /// from the counts alone, naming the cell texture, its texels, the limit and the two
    /// options that exist, in one line; the texture the slots take is 11.6 times the cells'
    /// dense texels. The 36-sphere scene's counts fit.
    #[test]
    fn spheres_100_irregular_is_refused_from_counts() {
        let counts = |triangles: u64, cells: u64| LayoutCounts {
            triangles,
            normals: true,
            materials: 2,
            grid: GridCounts::Irregular {
                cells,
                refs: triangles * 5,
                vmap_entries: cells * 2,
            },
            tex_texels: None,
            inst_texels: None,
            format: IndexFormat::Split,
        };
        let cells = 61_500_880;
        let plan = LayoutPlan::new(&counts(32_768_002, cells));
        let texels = irregular_cell_texels(cells, IndexFormat::Split);
        assert_eq!(texels, 2_144_492_355);
        assert!(
            texels > 11 * 3 * cells && texels < 12 * 3 * cells,
            "{texels}"
        );
        let e = plan.check(32768, None).unwrap_err();
        assert!(matches!(e, Error::Limit(_)), "{e}");
        let text = e.to_string();
        assert!(!text.contains('\n'), "{text}");
        for want in [
            "texture `cell` needs 2144492355 texels, 32768x65445",
            "GL_MAX_TEXTURE_SIZE is 32768",
            "--accel uniform, or --backend cpu",
        ] {
            assert!(text.contains(want), "{text}");
        }
        // 36 spheres: 11.8 M triangles, about 22 M cells (1.875 per triangle).
        let fits = LayoutPlan::new(&counts(11_796_482, 22_118_403));
        assert!(fits.check(32768, None).is_ok());
        // Its textures: 1.3 GB of slot-spaced cells beside 0.57 GB each of tri and nrm.
        let gb = |b: u64| b as f64 / 1e9;
        let cell = gb(fits.bytes_of("cell", 32768));
        assert!((1.2..1.4).contains(&cell), "{cell}");
        assert!((0.5..0.6).contains(&gb(fits.bytes_of("tri", 32768))));
    }

    /// The 100-sphere scene's counts in the compute kernel's dense layout (61.5 M cells
    /// from the H100's refusal; 5.31 references and 2 voxel-map entries a triangle, the
    /// 12-sphere scene's 20.9 M references over 3.93 M triangles): no texture of the grid,
    /// fits a GPU of 32768-texel textures and 2 GiB storage blocks (each buffer under 1 GB),
    /// and takes 32 bytes a cell where the slots took 11.6 times 48.
    #[test]
    fn spheres_100_irregular_fits_the_dense_layout() {
        let (triangles, cells) = (32_768_002u64, 61_500_880u64);
        let refs = triangles * 531 / 100;
        let plan = LayoutPlan::new(&LayoutCounts {
            triangles,
            normals: true,
            materials: 2,
            grid: GridCounts::Dense {
                cells,
                refs,
                vmap_entries: 2 * triangles,
            },
            tex_texels: None,
            inst_texels: None,
            format: IndexFormat::Split,
        });
        let names: Vec<&str> = plan.textures.iter().map(|&(n, _)| n).collect();
        assert_eq!(names, ["tri", "nrm", "mat"]);
        assert!(plan.check(32768, None).is_ok());
        for &(name, bytes) in &plan.buffers {
            assert!(bytes < 1_000_000_000, "{name}: {bytes}");
        }
        let cell_bytes: u64 = plan
            .buffers
            .iter()
            .filter(|(n, _)| n.starts_with("dense_cell"))
            .map(|&(_, b)| b)
            .sum();
        assert_eq!(cell_bytes, 32 * cells);
        // Everything the layout uploads: about 185 bytes a triangle (tri and nrm 48 each,
        // cells 60, references 21, voxel map 8), where the float layout's cell texture
        // alone took 1,047.
        let per = plan.bytes(32768) as f64 / triangles as f64;
        assert!((180.0..200.0).contains(&per), "{per}");
    }

    /// The uniform grid's cell texture beyond the limit names the options that change it;
    /// the triangle texture only the CPU.
    #[test]
    fn advice_follows_the_texture() {
        let plan = |triangles, cells| {
            LayoutPlan::new(&LayoutCounts {
                triangles,
                normals: false,
                materials: 1,
                grid: GridCounts::Uniform { cells, refs: 10 },
                tex_texels: None,
                inst_texels: None,
                format: IndexFormat::Float,
            })
        };
        let e = plan(10, 64 * 64 + 1)
            .check(64, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("`cell`") && e.contains("--grid-density"), "{e}");
        let e = plan(2000, 10).check(64, None).unwrap_err().to_string();
        assert!(
            e.contains("`tri`") && e.ends_with("render it with --backend cpu"),
            "{e}"
        );
        assert!(plan(1000, 64 * 64).check(64, None).is_ok());
    }

    /// Host memory: twice the textures' bytes (theirs and the driver's copy) must be
    /// available; the refusal names the need, the largest texture and what there is.
    #[test]
    fn memory_beyond_what_is_available_is_refused() {
        let c = LayoutCounts {
            triangles: 1 << 20,
            normals: false,
            materials: 1,
            grid: GridCounts::Irregular {
                cells: 1 << 21,
                refs: 5 << 20,
                vmap_entries: 1 << 22,
            },
            tex_texels: None,
            inst_texels: None,
            format: IndexFormat::Float,
        };
        let plan = LayoutPlan::new(&c);
        let bytes = plan.bytes(16384);
        // tri 3 Mi texels, cell 4 Mi, list 5 Mi / 4, vmap 1 Mi, mat one row: 16 B each.
        let texels = (3 << 20) + (4 << 20) + (5 << 18) + (1 << 20) + 8;
        assert_eq!(bytes, texels * TEXEL_BYTES);
        assert!(plan.check(16384, Some(2 * bytes)).is_ok());
        let e = plan.check(16384, Some(2 * bytes - 1)).unwrap_err();
        let text = e.to_string();
        assert!(
            matches!(e, Error::Limit(_)) && !text.contains('\n'),
            "{text}"
        );
        assert!(
            text.contains("the largest `cell` of 4194304 texels"),
            "{text}"
        );
        assert!(text.contains("--accel uniform, or --backend cpu"), "{text}");
    }
}
