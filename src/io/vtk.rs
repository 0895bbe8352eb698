//! VTK output: one XML UnstructuredGrid (`.vtu`) file per frame, plus a
//! ParaView collection (`.pvd`) file listing the frames of a time series.
//!
//! # Format
//!
//! * `.vtu` files are VTK XML UnstructuredGrid, version 1.0, little endian,
//!   UInt64 headers, inline base64 binary with ZLib compression
//!   ([`COMPRESSION_LEVEL`]). ParaView, pyvista and meshio all read them.
//!   (The legacy binary format, LZ4 and `.vtp` PolyData are deliberately not
//!   used: pyvista segfaults on legacy little-endian files and meshio does not
//!   read every `.vtp` variant.)
//! * The simulation is 2D: points are written with `z = 0`, all floating point
//!   data as `Float64`, integer data as `Int32`.
//! * Arrays are written in the order given; the first scalar, vector and tensor
//!   array of a frame are marked as the active ones (`Scalars=`, `Vectors=`,
//!   `Tensors=` attributes).
//!
//! # Array representation
//!
//! | [`Data`] variant        | components written                                  |
//! |-------------------------|-----------------------------------------------------|
//! | `Scalar(&[f64])`        | 1 (`Float64`)                                       |
//! | `Int(&[i32])`           | 1 (`Int32`)                                         |
//! | `Vector(&[[f64; 2]])`   | 3: `x, y, 0`                                        |
//! | `Tensor { inplane, zz }`| 9, row-major 3x3: `xx, xy, 0, yx, yy, 0, 0, 0, zz`  |
//!
//! For every tensor array a derived scalar array with the von Mises equivalent
//! stress of the 3x3 tensor ([`von_mises`]) is written right after it. It is
//! called `von_mises` when the tensor is called `stress`, and
//! `<name>_von_mises` otherwise.
//!
//! # Cells
//!
//! * A frame without lines ([`Frame::lines`] is `None`) has one `VTK_VERTEX`
//!   cell per point, so ParaView and pyvista show the points directly.
//! * A frame with lines has one `VTK_LINE` cell per pair and *no* vertex
//!   cells, so that cell data is exactly one value per line. Write a contact
//!   network as its own `.vtu` (its own series, e.g. `contacts.pvd`), separate
//!   from the grain frame (e.g. `series.pvd`).
//!
//! # Atomicity
//!
//! [`write_vtu`] and [`Series::write_pvd`] write to a hidden temporary file in
//! the target directory (`.<name>.tmp-<pid>-<n>`), fsync it, and rename it
//! over the target, so readers never see a half-written file. On error the
//! temporary file is removed.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use vtkio::model::{
    Attribute, Attributes, ByteOrder, CellType, Cells, DataArray, DataSet, ElementType, IOBuffer,
    UnstructuredGridPiece, Version, VertexNumbers, Vtk,
};
use vtkio::xml::Compressor;

/// ZLib compression level used for `.vtu` files (0 = none, 9 = smallest).
pub const COMPRESSION_LEVEL: u32 = 5;

/// Name of the series used for grain / particle frames; the Python check
/// (`tests/python/check_vtk.py`) looks for `series.pvd` files.
pub const DEFAULT_SERIES: &str = "series";

/// One frame: 2D points (written with `z = 0`), named per-point data, and
/// optionally line cells with per-line data.
#[derive(Clone, Debug)]
pub struct Frame<'a> {
    pub points: &'a [[f64; 2]],
    /// Per-point arrays; each must have `points.len()` entries.
    pub point_data: Vec<(&'a str, Data<'a>)>,
    /// If `Some`, the file holds `VTK_LINE` cells (and no vertex cells);
    /// otherwise one `VTK_VERTEX` cell per point.
    pub lines: Option<Lines<'a>>,
}

impl<'a> Frame<'a> {
    /// A frame with the given points, no data and no lines.
    pub fn new(points: &'a [[f64; 2]]) -> Self {
        Frame {
            points,
            point_data: Vec::new(),
            lines: None,
        }
    }

    /// Adds a point data array (builder style).
    pub fn with(mut self, name: &'a str, data: Data<'a>) -> Self {
        self.point_data.push((name, data));
        self
    }

    /// Sets the line cells (builder style).
    pub fn with_lines(mut self, lines: Lines<'a>) -> Self {
        self.lines = Some(lines);
        self
    }
}

/// A data array, one entry per point (or per line for cell data).
#[derive(Clone, Copy, Debug)]
pub enum Data<'a> {
    /// Written as 1 `Float64` component.
    Scalar(&'a [f64]),
    /// Written as 1 `Int32` component.
    Int(&'a [i32]),
    /// 2D vector, written as 3 components `x, y, 0`.
    Vector(&'a [[f64; 2]]),
    /// 2x2 in-plane tensor in row-major order `[xx, xy, yx, yy]`, plus an
    /// optional out-of-plane `zz` component (e.g. the MPM Cauchy stress in
    /// plane strain, where `zz != 0`; `None` writes `zz = 0`). Written as 9
    /// components, row-major 3x3: `xx, xy, 0, yx, yy, 0, 0, 0, zz`. A derived
    /// von Mises array is written as well (see the module docs).
    Tensor {
        inplane: &'a [[f64; 4]],
        zz: Option<&'a [f64]>,
    },
}

impl<'a> Data<'a> {
    /// An in-plane tensor with `zz = 0`.
    pub fn tensor(inplane: &'a [[f64; 4]]) -> Self {
        Data::Tensor { inplane, zz: None }
    }

    /// A plane-strain tensor: in-plane components plus `zz`.
    pub fn tensor_zz(inplane: &'a [[f64; 4]], zz: &'a [f64]) -> Self {
        Data::Tensor {
            inplane,
            zz: Some(zz),
        }
    }

    /// Number of entries (points or lines) in this array.
    pub fn len(&self) -> usize {
        match self {
            Data::Scalar(v) => v.len(),
            Data::Int(v) => v.len(),
            Data::Vector(v) => v.len(),
            Data::Tensor { inplane, .. } => inplane.len(),
        }
    }

    /// `true` if the array has no entries.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Line cells, e.g. a contact force network: one line per contact between two
/// point indices, with per-line cell data (e.g. `normal_force`).
#[derive(Clone, Debug)]
pub struct Lines<'a> {
    /// Point index pairs; each index must be `< points.len()`.
    pub pairs: &'a [[u32; 2]],
    /// Per-line arrays; each must have `pairs.len()` entries.
    pub cell_data: Vec<(&'a str, Data<'a>)>,
}

/// Von Mises equivalent stress of the 3x3 tensor
/// `[[xx, xy, 0], [yx, yy, 0], [0, 0, zz]]` (`t = [xx, xy, yx, yy]`), using
/// the symmetric part for the shear: `sqrt(((xx-yy)² + (yy-zz)² + (zz-xx)²)/2
/// + 3·((xy+yx)/2)²)`. Always `>= 0` (NaN for non-finite input).
pub fn von_mises(t: [f64; 4], zz: f64) -> f64 {
    let [xx, xy, yx, yy] = t;
    let s = 0.5 * (xy + yx);
    (0.5 * ((xx - yy).powi(2) + (yy - zz).powi(2) + (zz - xx).powi(2)) + 3.0 * s * s).sqrt()
}

fn invalid(msg: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, msg)
}

/// Converts named arrays into vtkio attributes (plus derived von Mises arrays),
/// checking lengths and name uniqueness.
fn attributes(arrays: &[(&str, Data)], n: usize, what: &str) -> io::Result<Vec<Attribute>> {
    let mut out: Vec<Attribute> = Vec::with_capacity(arrays.len());
    let mut names: Vec<String> = Vec::with_capacity(arrays.len());
    let mut push_name = |name: String| -> io::Result<()> {
        if name.is_empty() {
            return Err(invalid(format!("empty {what} array name")));
        }
        if names.contains(&name) {
            return Err(invalid(format!("duplicate {what} array name {name:?}")));
        }
        names.push(name);
        Ok(())
    };
    for &(name, data) in arrays {
        if data.len() != n {
            return Err(invalid(format!(
                "{what} array {name:?} has {} entries, expected {n}",
                data.len()
            )));
        }
        push_name(name.to_string())?;
        let scalars = ElementType::Scalars {
            num_comp: 1,
            lookup_table: None,
        };
        match data {
            Data::Scalar(v) => out.push(Attribute::DataArray(DataArray {
                name: name.to_string(),
                elem: scalars,
                data: IOBuffer::F64(v.to_vec()),
            })),
            Data::Int(v) => out.push(Attribute::DataArray(DataArray {
                name: name.to_string(),
                elem: scalars,
                data: IOBuffer::I32(v.to_vec()),
            })),
            Data::Vector(v) => out.push(Attribute::DataArray(DataArray {
                name: name.to_string(),
                elem: ElementType::Vectors,
                data: IOBuffer::F64(v.iter().flat_map(|&[x, y]| [x, y, 0.0]).collect()),
            })),
            Data::Tensor { inplane, zz } => {
                if let Some(zz) = zz
                    && zz.len() != n
                {
                    return Err(invalid(format!(
                        "{what} tensor {name:?} has {} zz entries, expected {n}",
                        zz.len()
                    )));
                }
                let zz_at = |i: usize| zz.map_or(0.0, |z| z[i]);
                let mut full = Vec::with_capacity(9 * n);
                let mut vm = Vec::with_capacity(n);
                for (i, &t) in inplane.iter().enumerate() {
                    let [xx, xy, yx, yy] = t;
                    let z = zz_at(i);
                    full.extend_from_slice(&[xx, xy, 0.0, yx, yy, 0.0, 0.0, 0.0, z]);
                    vm.push(von_mises(t, z));
                }
                out.push(Attribute::DataArray(DataArray {
                    name: name.to_string(),
                    elem: ElementType::Tensors,
                    data: IOBuffer::F64(full),
                }));
                let vm_name = if name == "stress" {
                    "von_mises".to_string()
                } else {
                    format!("{name}_von_mises")
                };
                push_name(vm_name.clone())?;
                out.push(Attribute::DataArray(DataArray {
                    name: vm_name,
                    elem: ElementType::Generic(1),
                    data: IOBuffer::F64(vm),
                }));
            }
        }
    }
    Ok(out)
}

/// Builds the vtkio model of a frame (validates all sizes and indices).
fn frame_to_vtk(frame: &Frame) -> io::Result<Vtk> {
    let n = frame.points.len();
    let point_attrs = attributes(&frame.point_data, n, "point")?;
    let (cells, cell_attrs) = match &frame.lines {
        None => (
            Cells {
                cell_verts: VertexNumbers::XML {
                    connectivity: (0..n as u64).collect(),
                    offsets: (1..=n as u64).collect(),
                },
                types: vec![CellType::Vertex; n],
            },
            Vec::new(),
        ),
        Some(lines) => {
            let m = lines.pairs.len();
            if let Some((k, p)) = lines
                .pairs
                .iter()
                .enumerate()
                .find(|(_, p)| p.iter().any(|&i| i as usize >= n))
            {
                return Err(invalid(format!(
                    "line {k} = {p:?} references a point index >= {n}"
                )));
            }
            (
                Cells {
                    cell_verts: VertexNumbers::XML {
                        connectivity: lines
                            .pairs
                            .iter()
                            .flat_map(|&[a, b]| [u64::from(a), u64::from(b)])
                            .collect(),
                        offsets: (1..=m as u64).map(|k| 2 * k).collect(),
                    },
                    types: vec![CellType::Line; m],
                },
                attributes(&lines.cell_data, m, "cell")?,
            )
        }
    };
    let points: Vec<f64> = frame
        .points
        .iter()
        .flat_map(|&[x, y]| [x, y, 0.0])
        .collect();
    Ok(Vtk {
        version: Version::new_xml(1, 0),
        byte_order: ByteOrder::LittleEndian,
        title: String::new(),
        file_path: None,
        data: DataSet::inline(UnstructuredGridPiece {
            points: IOBuffer::F64(points),
            cells,
            data: Attributes {
                point: point_attrs,
                cell: cell_attrs,
            },
        }),
    })
}

static TMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `path` atomically: temp file in the same directory, fsync, rename.
fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    let name = path
        .file_name()
        .ok_or_else(|| invalid(format!("{} has no file name", path.display())))?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let tmp = dir.join(format!(
        ".{}.tmp-{}-{}",
        name.to_string_lossy(),
        std::process::id(),
        TMP_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let result = (|| {
        let file = OpenOptions::new().write(true).create_new(true).open(&tmp)?;
        let mut w = BufWriter::new(file);
        write(&mut w)?;
        let file = w.into_inner().map_err(io::IntoInnerError::into_error)?;
        file.sync_all()?;
        drop(file);
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result?;
    // Persist the rename itself (best effort; not supported everywhere).
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// Writes one frame as a ZLib-compressed XML UnstructuredGrid `.vtu` file
/// (level [`COMPRESSION_LEVEL`]), atomically. Returns `InvalidInput` if an
/// array length, a zz length or a line index does not match the points, or if
/// array names are empty or repeated.
///
/// Cost (vtkio 0.7.0-rc2 feeds zlib one value at a time): about 7 µs and
/// 56 bytes per point for points + 17 values per point; see [`write_vtu_with`]
/// for uncompressed output, which is ~4x faster to encode and ~3.7x larger.
pub fn write_vtu(path: &Path, frame: &Frame) -> io::Result<()> {
    write_vtu_with(path, frame, COMPRESSION_LEVEL)
}

/// As [`write_vtu`], with a ZLib compression level from 0 to 9; 0 writes
/// uncompressed (still base64 binary) data.
pub fn write_vtu_with(path: &Path, frame: &Frame, level: u32) -> io::Result<()> {
    if level > 9 {
        return Err(invalid(format!("compression level {level} > 9")));
    }
    let vtk = frame_to_vtk(frame)?;
    let compressor = if level == 0 {
        Compressor::None
    } else {
        Compressor::ZLib
    };
    let xml = vtk
        .try_into_xml_format(compressor, level)
        .map_err(|e| io::Error::other(format!("vtkio: {e}")))?;
    write_atomic(path, |w| {
        xml.write(&mut *w)
            .map_err(|e| io::Error::other(format!("vtkio: {e}")))
    })
}

/// A time series of frames, written as a ParaView `.pvd` collection.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Series {
    /// `(time, file name relative to the .pvd file)`, in push order.
    entries: Vec<(f64, String)>,
}

impl Series {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a frame; `file` is relative to the directory of the `.pvd` file.
    pub fn push(&mut self, time: f64, file: &str) {
        self.entries.push((time, file.to_string()));
    }

    /// The `(time, file)` entries in push order.
    pub fn entries(&self) -> &[(f64, String)] {
        &self.entries
    }

    /// Renders the `.pvd` XML text.
    pub fn to_pvd_string(&self) -> io::Result<String> {
        use std::fmt::Write as _;
        let mut s = String::from(
            "<?xml version=\"1.0\"?>\n\
             <VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  \
             <Collection>\n",
        );
        for (time, file) in &self.entries {
            if !time.is_finite() {
                return Err(invalid(format!("non-finite time {time} for {file:?}")));
            }
            // `{:?}` is the shortest representation that round-trips, e.g.
            // `0.0`, `0.25`, `1e-7`; ParaView and Python parse it.
            writeln!(
                s,
                "    <DataSet timestep=\"{time:?}\" group=\"\" part=\"0\" file=\"{}\"/>",
                xml_escape(file)
            )
            .expect("writing to a String");
        }
        s.push_str("  </Collection>\n</VTKFile>\n");
        Ok(s)
    }

    /// Writes the `.pvd` collection file atomically.
    pub fn write_pvd(&self, path: &Path) -> io::Result<()> {
        let text = self.to_pvd_string()?;
        write_atomic(path, |w| w.write_all(text.as_bytes()))
    }
}

fn xml_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

/// Writes a numbered series into one directory: frames
/// `<dir>/<name>_000000.vtu`, `<name>_000001.vtu`, ... and the collection
/// `<dir>/<name>.pvd`, which is rewritten after every frame so that an
/// interrupted run still leaves a valid series. Use [`DEFAULT_SERIES`]
/// (`series`) for grain/particle frames and e.g. `contacts` for line networks.
#[derive(Clone, Debug)]
pub struct SeriesWriter {
    dir: PathBuf,
    name: String,
    series: Series,
}

impl SeriesWriter {
    /// Creates `dir` (and parents) if needed. Starts an empty series; an
    /// existing `<name>.pvd` is overwritten at the first frame.
    pub fn new(dir: impl Into<PathBuf>, name: &str) -> io::Result<Self> {
        let dir = dir.into();
        if name.is_empty() || name.contains(['/', '\\']) {
            return Err(invalid(format!("invalid series name {name:?}")));
        }
        fs::create_dir_all(&dir)?;
        Ok(SeriesWriter {
            dir,
            name: name.to_string(),
            series: Series::new(),
        })
    }

    /// Writes the next frame at `time`, then rewrites the `.pvd`. Returns the
    /// path of the `.vtu` written.
    pub fn write(&mut self, time: f64, frame: &Frame) -> io::Result<PathBuf> {
        if !time.is_finite() {
            return Err(invalid(format!("non-finite time {time}")));
        }
        let file = format!("{}_{:06}.vtu", self.name, self.series.entries.len());
        let path = self.dir.join(&file);
        write_vtu(&path, frame)?;
        self.series.push(time, &file);
        self.series.write_pvd(&self.pvd_path())?;
        Ok(path)
    }

    /// Path of the `.pvd` collection file.
    pub fn pvd_path(&self) -> PathBuf {
        self.dir.join(format!("{}.pvd", self.name))
    }

    /// The frames written so far.
    pub fn series(&self) -> &Series {
        &self.series
    }
}
