//! Round-trip tests of `softgrain::io::vtk` (read back with vtkio's importer),
//! `.pvd` well-formedness, atomic writes, and sample output for
//! `tests/python/check_vtk.py`.
//!
//! `sample_output` leaves frames in `$CARGO_TARGET_TMPDIR/vtk-sample/` (i.e.
//! `<target dir>/tmp/vtk-sample/`, override with env `VTK_SAMPLE_DIR`) and a
//! deliberately broken series in `.../vtk-sample-bad/`.

use std::collections::HashMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use softgrain::io::vtk::{
    DEFAULT_SERIES, Data, Frame, Lines, Series, SeriesWriter, von_mises, write_vtu, write_vtu_with,
};
use vtkio::Vtk;
use vtkio::model::{Attribute, CellType, IOBuffer, UnstructuredGridPiece, VertexNumbers};

/// A fresh, unique directory under the system temp dir.
fn temp_dir(tag: &str) -> PathBuf {
    let nanos = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_nanos();
    let dir = std::env::temp_dir().join(format!(
        "softgrain-vtk-{tag}-{}-{nanos}",
        std::process::id()
    ));
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn dir_listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn read_piece(path: &Path) -> UnstructuredGridPiece {
    let vtk = Vtk::import(path).unwrap_or_else(|e| panic!("import {}: {e}", path.display()));
    UnstructuredGridPiece::try_from(vtk.data).expect("one UnstructuredGrid piece")
}

/// name -> (number of components, data)
fn arrays(attrs: &[Attribute]) -> HashMap<String, (usize, IOBuffer)> {
    attrs
        .iter()
        .map(|a| match a {
            Attribute::DataArray(d) => (d.name.clone(), (d.num_comp(), d.data.clone())),
            Attribute::Field { name, .. } => panic!("unexpected field attribute {name}"),
        })
        .collect()
}

fn f64s(buf: &IOBuffer) -> Vec<f64> {
    match buf {
        IOBuffer::F64(v) => v.clone(),
        other => panic!("expected Float64 data, got {:?}", other.scalar_type()),
    }
}

fn xml_cells(piece: &UnstructuredGridPiece) -> (Vec<u64>, Vec<u64>) {
    match &piece.cells.cell_verts {
        VertexNumbers::XML {
            connectivity,
            offsets,
        } => (connectivity.clone(), offsets.clone()),
        VertexNumbers::Legacy { .. } => panic!("expected XML cell layout"),
    }
}

const POINTS: [[f64; 2]; 5] = [
    [0.0, 0.0],
    [1.5, -0.25],
    [-3.0, 2.0],
    [1e-9, 7.0e3],
    [0.1, 0.2],
];
const GRAIN_ID: [i32; 5] = [0, 1, 1, -7, i32::MAX];
const RADIUS: [f64; 5] = [0.5, 0.25, 1e-6, 3.0, 0.1];
const VELOCITY: [[f64; 2]; 5] = [
    [1.0, 2.0],
    [-1.0, 0.0],
    [0.0, 0.0],
    [1e10, -1e-10],
    [0.3, 0.7],
];
const STRESS: [[f64; 4]; 5] = [
    [1.0, 0.0, 0.0, 1.0],
    [-2.0, 0.5, 0.5, 3.0],
    [0.0, 1.0, 1.0, 0.0],
    [1e6, -2e5, -2e5, -3e6],
    [0.0, 0.0, 0.0, 0.0],
];
const STRESS_ZZ: [f64; 5] = [1.0, 0.4, 0.0, -5e5, 0.0];

#[test]
fn frame_round_trips_through_vtkio() {
    let dir = temp_dir("frame");
    let path = dir.join("frame.vtu");
    let frame = Frame::new(&POINTS)
        .with("grain_id", Data::Int(&GRAIN_ID))
        .with("radius", Data::Scalar(&RADIUS))
        .with("velocity", Data::Vector(&VELOCITY))
        .with("stress", Data::tensor_zz(&STRESS, &STRESS_ZZ));
    write_vtu(&path, &frame).unwrap();

    // Header: XML UnstructuredGrid, ZLib compressed, little endian.
    let text = fs::read_to_string(&path).unwrap();
    assert!(text.contains(r#"type="UnstructuredGrid""#), "{text}");
    assert!(text.contains(r#"compressor="vtkZLibDataCompressor""#));
    assert!(text.contains(r#"byte_order="LittleEndian""#));

    let piece = read_piece(&path);
    assert_eq!(piece.num_points(), 5);
    let pts = f64s(&piece.points);
    for (i, p) in POINTS.iter().enumerate() {
        assert_eq!(&pts[3 * i..3 * i + 3], &[p[0], p[1], 0.0]);
    }

    // One vertex cell per point.
    assert_eq!(piece.cells.types, vec![CellType::Vertex; 5]);
    let (conn, offsets) = xml_cells(&piece);
    assert_eq!(conn, vec![0, 1, 2, 3, 4]);
    assert_eq!(offsets, vec![1, 2, 3, 4, 5]);

    let a = arrays(&piece.data.point);
    let mut names: Vec<&str> = a.keys().map(String::as_str).collect();
    names.sort();
    assert_eq!(
        names,
        ["grain_id", "radius", "stress", "velocity", "von_mises"]
    );
    assert!(piece.data.cell.is_empty());

    let (nc, ids) = &a["grain_id"];
    assert_eq!(*nc, 1);
    assert_eq!(ids, &IOBuffer::I32(GRAIN_ID.to_vec()));

    let (nc, radius) = &a["radius"];
    assert_eq!(*nc, 1);
    assert_eq!(f64s(radius), RADIUS.to_vec());

    let (nc, vel) = &a["velocity"];
    assert_eq!(*nc, 3);
    let expected: Vec<f64> = VELOCITY.iter().flat_map(|v| [v[0], v[1], 0.0]).collect();
    assert_eq!(f64s(vel), expected);

    let (nc, stress) = &a["stress"];
    assert_eq!(*nc, 9);
    let expected: Vec<f64> = STRESS
        .iter()
        .zip(STRESS_ZZ)
        .flat_map(|(t, zz)| [t[0], t[1], 0.0, t[2], t[3], 0.0, 0.0, 0.0, zz])
        .collect();
    assert_eq!(f64s(stress), expected);

    let (nc, vm) = &a["von_mises"];
    assert_eq!(*nc, 1);
    let vm = f64s(vm);
    for i in 0..5 {
        assert_eq!(vm[i], von_mises(STRESS[i], STRESS_ZZ[i]));
        assert!(vm[i] >= 0.0);
    }
    // Spot checks of the von Mises formula.
    assert_eq!(vm[0], 0.0); // hydrostatic
    assert_eq!(vm[4], 0.0);
    assert!((vm[2] - 3f64.sqrt()).abs() < 1e-15); // pure shear 1
    assert!((von_mises([1.0, 0.0, 0.0, 0.0], 0.0) - 1.0).abs() < 1e-15); // uniaxial

    // Uncompressed output reads back identically.
    let raw = dir.join("raw.vtu");
    write_vtu_with(&raw, &frame, 0).unwrap();
    assert!(!fs::read_to_string(&raw).unwrap().contains("compressor"));
    assert_eq!(read_piece(&raw), piece);
    assert!(write_vtu_with(&raw, &frame, 10).is_err());
    fs::remove_file(&raw).unwrap();

    // Only the target file; no temporary left behind.
    assert_eq!(dir_listing(&dir), ["frame.vtu"]);

    // Overwriting an existing file works and stays atomic.
    let frame2 = Frame::new(&POINTS[..2]).with("radius", Data::Scalar(&RADIUS[..2]));
    write_vtu(&path, &frame2).unwrap();
    assert_eq!(read_piece(&path).num_points(), 2);
    assert_eq!(dir_listing(&dir), ["frame.vtu"]);
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn line_network_round_trips() {
    let dir = temp_dir("lines");
    let path = dir.join("contacts.vtu");
    let centres = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let ids = [10, 11, 12, 13];
    let pairs = [[0u32, 1], [1, 2], [2, 3], [3, 0], [0, 2]];
    let fnorm = [1.0, 2.5, 0.0, 1e-3, 4.0];
    let branch = [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [1.0, 1.0]];
    let frame = Frame::new(&centres)
        .with("grain_id", Data::Int(&ids))
        .with_lines(Lines {
            pairs: &pairs,
            cell_data: vec![
                ("normal_force", Data::Scalar(&fnorm)),
                ("branch", Data::Vector(&branch)),
            ],
        });
    write_vtu(&path, &frame).unwrap();

    let piece = read_piece(&path);
    assert_eq!(piece.num_points(), 4);
    assert_eq!(piece.cells.types, vec![CellType::Line; 5]);
    let (conn, offsets) = xml_cells(&piece);
    assert_eq!(conn, vec![0, 1, 1, 2, 2, 3, 3, 0, 0, 2]);
    assert_eq!(offsets, vec![2, 4, 6, 8, 10]);

    let p = arrays(&piece.data.point);
    assert_eq!(p["grain_id"].1, IOBuffer::I32(ids.to_vec()));
    let c = arrays(&piece.data.cell);
    assert_eq!(c.len(), 2);
    assert_eq!(c["normal_force"].0, 1);
    assert_eq!(f64s(&c["normal_force"].1), fnorm.to_vec());
    assert_eq!(c["branch"].0, 3);
    assert_eq!(
        f64s(&c["branch"].1),
        branch
            .iter()
            .flat_map(|b| [b[0], b[1], 0.0])
            .collect::<Vec<_>>()
    );
    assert_eq!(dir_listing(&dir), ["contacts.vtu"]);
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn invalid_frames_are_rejected_without_leaving_files() {
    let dir = temp_dir("invalid");
    let path = dir.join("bad.vtu");
    let pts = [[0.0, 0.0], [1.0, 1.0]];
    let cases: Vec<Frame> = vec![
        // wrong length
        Frame::new(&pts).with("radius", Data::Scalar(&[1.0])),
        // wrong zz length
        Frame::new(&pts).with(
            "stress",
            Data::tensor_zz(&[[0.0; 4], [0.0; 4]], &[1.0, 2.0, 3.0]),
        ),
        // duplicate name, also with a derived von Mises name
        Frame::new(&pts)
            .with("radius", Data::Scalar(&[1.0, 1.0]))
            .with("radius", Data::Scalar(&[1.0, 1.0])),
        Frame::new(&pts)
            .with("von_mises", Data::Scalar(&[1.0, 1.0]))
            .with("stress", Data::tensor(&[[0.0; 4], [0.0; 4]])),
        // empty name
        Frame::new(&pts).with("", Data::Int(&[1, 2])),
        // line index out of range
        Frame::new(&pts).with_lines(Lines {
            pairs: &[[0, 2]],
            cell_data: vec![],
        }),
        // cell data length
        Frame::new(&pts).with_lines(Lines {
            pairs: &[[0, 1]],
            cell_data: vec![("normal_force", Data::Scalar(&[1.0, 2.0]))],
        }),
    ];
    for (k, frame) in cases.iter().enumerate() {
        let err = write_vtu(&path, frame).expect_err(&format!("case {k} must fail"));
        assert_eq!(err.kind(), std::io::ErrorKind::InvalidInput, "case {k}");
    }
    // Writing into a missing directory fails cleanly.
    let missing = dir.join("no/such/dir/x.vtu");
    assert!(write_vtu(&missing, &Frame::new(&pts)).is_err());
    assert!(dir_listing(&dir).is_empty());
    fs::remove_dir_all(&dir).unwrap();
}

/// Minimal XML well-formedness check (declaration, balanced tags, quoted
/// attributes, single root); returns the elements as (name, attributes).
fn parse_xml(text: &str) -> Vec<(String, HashMap<String, String>)> {
    let mut elements = Vec::new();
    let mut stack: Vec<String> = Vec::new();
    let mut roots = 0;
    let mut rest = text.trim_start();
    assert!(rest.starts_with("<?xml"), "missing XML declaration");
    rest = &rest[rest.find("?>").expect("unterminated declaration") + 2..];
    loop {
        let lt = match rest.find('<') {
            Some(i) => i,
            None => {
                assert!(rest.trim().is_empty(), "trailing text {rest:?}");
                break;
            }
        };
        assert!(
            rest[..lt].trim().is_empty(),
            "unexpected text {:?}",
            &rest[..lt]
        );
        let gt = rest[lt..].find('>').expect("unterminated tag") + lt;
        let tag = &rest[lt + 1..gt];
        rest = &rest[gt + 1..];
        if let Some(name) = tag.strip_prefix('/') {
            assert_eq!(
                stack.pop().as_deref(),
                Some(name.trim()),
                "mismatched end tag"
            );
            continue;
        }
        let self_closing = tag.ends_with('/');
        let tag = tag.trim_end_matches('/');
        let (name, mut attrs_text) = tag.split_once(char::is_whitespace).unwrap_or((tag, ""));
        assert!(!name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric()));
        let mut attrs = HashMap::new();
        loop {
            attrs_text = attrs_text.trim_start();
            if attrs_text.is_empty() {
                break;
            }
            let (key, after) = attrs_text.split_once("=\"").expect("attribute without =\"");
            let end = after.find('"').expect("unterminated attribute value");
            let value = &after[..end];
            assert!(!value.contains('<'), "'<' in attribute value");
            assert!(
                attrs
                    .insert(key.trim().to_string(), value.to_string())
                    .is_none(),
                "duplicate attribute {key}"
            );
            attrs_text = &after[end + 1..];
        }
        if stack.is_empty() {
            roots += 1;
        }
        elements.push((name.to_string(), attrs));
        if !self_closing {
            stack.push(name.to_string());
        }
    }
    assert!(stack.is_empty(), "unclosed elements {stack:?}");
    assert_eq!(roots, 1, "exactly one root element");
    elements
}

#[test]
fn pvd_is_well_formed_with_the_right_entries() {
    let dir = temp_dir("pvd");
    let path = dir.join("series.pvd");
    let mut s = Series::new();
    let times = [0.0, 0.25, 1e-7, 12345.5];
    for (i, t) in times.iter().enumerate() {
        s.push(*t, &format!("frame_{i:06}.vtu"));
    }
    s.push(2.0, "sub dir/a&b.vtu");
    s.write_pvd(&path).unwrap();
    assert_eq!(dir_listing(&dir), ["series.pvd"]);

    let text = fs::read_to_string(&path).unwrap();
    let el = parse_xml(&text);
    assert_eq!(el[0].0, "VTKFile");
    assert_eq!(el[0].1["type"], "Collection");
    assert_eq!(el[1].0, "Collection");
    let ds: Vec<_> = el.iter().filter(|(n, _)| n == "DataSet").collect();
    assert_eq!(ds.len(), 5);
    assert_eq!(el.len(), 7);
    for (i, t) in times.iter().enumerate() {
        assert_eq!(ds[i].1["timestep"].parse::<f64>().unwrap(), *t);
        assert_eq!(ds[i].1["file"], format!("frame_{i:06}.vtu"));
    }
    assert_eq!(ds[4].1["file"], "sub dir/a&amp;b.vtu");

    // Non-finite times are rejected and leave the old file intact.
    s.push(f64::NAN, "nan.vtu");
    assert!(s.write_pvd(&path).is_err());
    assert_eq!(fs::read_to_string(&path).unwrap(), text);
    assert_eq!(dir_listing(&dir), ["series.pvd"]);
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn series_writer_numbers_frames_and_keeps_pvd_current() {
    let dir = temp_dir("writer").join("run");
    let mut w = SeriesWriter::new(&dir, DEFAULT_SERIES).unwrap();
    for step in 0..3 {
        let r = [1.0 + step as f64; 5];
        let path = w
            .write(
                0.5 * step as f64,
                &Frame::new(&POINTS).with("radius", Data::Scalar(&r)),
            )
            .unwrap();
        assert_eq!(path, dir.join(format!("series_{step:06}.vtu")));
        let el = parse_xml(&fs::read_to_string(w.pvd_path()).unwrap());
        assert_eq!(el.iter().filter(|(n, _)| n == "DataSet").count(), step + 1);
        assert_eq!(f64s(&arrays(&read_piece(&path).data.point)["radius"].1), r);
    }
    assert_eq!(
        dir_listing(&dir),
        [
            "series.pvd",
            "series_000000.vtu",
            "series_000001.vtu",
            "series_000002.vtu"
        ]
    );
    assert_eq!(
        w.series().entries()[2],
        (1.0, "series_000002.vtu".to_string())
    );
    assert!(w.write(f64::INFINITY, &Frame::new(&POINTS)).is_err());
    assert!(SeriesWriter::new(&dir, "a/b").is_err());
    fs::remove_dir_all(dir.parent().unwrap()).unwrap();
}

fn sample_dir() -> PathBuf {
    std::env::var_os("VTK_SAMPLE_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_TARGET_TMPDIR")).join("vtk-sample"))
}

/// Writes sample series for `tests/python/check_vtk.py`: a disk/BPM series
/// (`radius`), an MPM series (`volume`, plane-strain `stress`), and a contact
/// network (`contacts.pvd`, not checked by the script). A sibling directory
/// `<sample>-bad` gets a series that must fail the check.
#[test]
fn sample_output() {
    let root = sample_dir();
    let _ = fs::remove_dir_all(&root);

    // Disk / bonded-particle frames: 3x3 grains on a lattice.
    let n: usize = 9;
    let ids: Vec<i32> = (0..n as i32).collect();
    let mut bpm = SeriesWriter::new(root.join("bpm"), DEFAULT_SERIES).unwrap();
    let mut contacts = SeriesWriter::new(root.join("bpm"), "contacts").unwrap();
    for step in 0..3 {
        let t = 1e-3 * step as f64;
        let pts: Vec<[f64; 2]> = (0..n)
            .map(|i| [(i % 3) as f64, (i / 3) as f64 - t])
            .collect();
        let radius: Vec<f64> = (0..n).map(|i| 0.45 + 0.01 * i as f64).collect();
        let vel: Vec<[f64; 2]> = (0..n).map(|i| [0.0, -1.0 - 0.1 * i as f64]).collect();
        let stress: Vec<[f64; 4]> = (0..n)
            .map(|i| [-(i as f64), 0.1, 0.1, -2.0 * step as f64])
            .collect();
        let frame = Frame::new(&pts)
            .with("grain_id", Data::Int(&ids))
            .with("radius", Data::Scalar(&radius))
            .with("velocity", Data::Vector(&vel))
            .with("stress", Data::tensor(&stress));
        bpm.write(t, &frame).unwrap();
        let pairs = [[0u32, 1], [1, 2], [0, 3], [3, 4], [4, 5], [1, 4]];
        let fnorm = [1.0, 2.0, 3.0, 0.5, 0.0, 1.5];
        let net = Frame::new(&pts)
            .with("grain_id", Data::Int(&ids))
            .with_lines(Lines {
                pairs: &pairs,
                cell_data: vec![("normal_force", Data::Scalar(&fnorm))],
            });
        contacts.write(t, &net).unwrap();
    }

    // Disk frames written uncompressed with the bare `Series` API.
    let disk = root.join("disk");
    fs::create_dir_all(&disk).unwrap();
    let mut series = Series::new();
    for step in 0..2 {
        let pts = [[0.0, 0.0], [2.0, 0.0], [1.0, 1.7]];
        let radius = [1.0, 1.0, 0.9 + 0.05 * step as f64];
        let frame = Frame::new(&pts)
            .with("grain_id", Data::Int(&[3, 4, 5]))
            .with("radius", Data::Scalar(&radius))
            .with(
                "velocity",
                Data::Vector(&[[0.0, 0.0], [0.0, 0.0], [0.0, -9.81]]),
            );
        let file = format!("disk_{step:04}.vtu");
        write_vtu_with(&disk.join(&file), &frame, 0).unwrap();
        series.push(0.1 * step as f64, &file);
    }
    series.write_pvd(&disk.join("series.pvd")).unwrap();

    // MPM material points: `volume` instead of `radius`, plane-strain stress.
    // 4096 points: every Float64 array is a whole number of vtkio's 32 KiB
    // compression blocks (vtkio then writes an empty trailing block).
    let mut mpm = SeriesWriter::new(root.join("mpm"), DEFAULT_SERIES).unwrap();
    for (step, m) in [(0, 20), (1, 20), (2, 4096)] {
        let pts: Vec<[f64; 2]> = (0..m)
            .map(|i| [0.1 * i as f64, 0.05 * step as f64])
            .collect();
        let ids: Vec<i32> = (0..m as i32).map(|i| i / 10).collect();
        let volume = vec![0.01; m];
        let vel = vec![[0.5, -0.5]; m];
        let stress: Vec<[f64; 4]> = (0..m)
            .map(|i| [-1.0, 0.2 * i as f64, 0.2 * i as f64, -3.0])
            .collect();
        let zz: Vec<f64> = (0..m).map(|i| -0.3 * i as f64).collect();
        let frame = Frame::new(&pts)
            .with("grain_id", Data::Int(&ids))
            .with("volume", Data::Scalar(&volume))
            .with("velocity", Data::Vector(&vel))
            .with("stress", Data::tensor_zz(&stress, &zz));
        mpm.write(0.01 * step as f64, &frame).unwrap();
    }

    // A broken series: zero radius, NaN velocity, missing grain_id in frame 1.
    let bad_root = root.with_file_name(format!(
        "{}-bad",
        root.file_name().unwrap().to_string_lossy()
    ));
    let _ = fs::remove_dir_all(&bad_root);
    let mut bad = SeriesWriter::new(&bad_root, DEFAULT_SERIES).unwrap();
    let pts = [[0.0, 0.0], [1.0, 0.0]];
    bad.write(
        0.0,
        &Frame::new(&pts)
            .with("grain_id", Data::Int(&[0, 1]))
            .with("radius", Data::Scalar(&[0.5, 0.0]))
            .with("velocity", Data::Vector(&[[0.0, 0.0], [f64::NAN, 0.0]])),
    )
    .unwrap();
    bad.write(
        1.0,
        &Frame::new(&pts)
            .with("radius", Data::Scalar(&[0.5, 0.5]))
            .with("velocity", Data::Vector(&[[0.0, 0.0], [0.0, 0.0]])),
    )
    .unwrap();

    eprintln!(
        "sample VTK output in {} (bad sample in {})",
        root.display(),
        bad_root.display()
    );
}
