//! `fts::io::mat` on the fixtures of tests/data/mat (written by
//! make_mat_fixtures.py; these tests need no Python): exact values, the
//! listing, every refusal's one-line message, and no panic and no large
//! allocation on random, truncated or mutated files.

use fts::io::mat::{
    MatClass, MatColumn, MatVariable, is_mat, read_columns, read_columns_from, variables,
};
use proptest::prelude::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::io::Write;
use std::path::PathBuf;

use crate::common;
use common::proptest_config as config;

/// Tracks the largest single allocation of the current thread.
struct Largest;

thread_local! {
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Largest {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = LARGEST.try_with(|c| c.set(c.get().max(layout.size())));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = LARGEST.try_with(|c| c.set(c.get().max(new_size)));
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Largest = Largest;

fn path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/mat")
        .join(name)
}

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(path(name)).unwrap()
}

fn cols(names: &[&str]) -> Vec<MatColumn> {
    names.iter().map(|n| MatColumn::parse(n)).collect()
}

/// The columns of expected.csv by header name.
fn expected(name: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(path("expected.csv")).unwrap();
    let mut lines = text.lines();
    let k = lines
        .next()
        .unwrap()
        .split(',')
        .position(|h| h == name)
        .unwrap();
    lines
        .map(|l| l.split(',').nth(k).unwrap().parse::<f64>().unwrap())
        .collect()
}

fn assert_bits(got: &[f64], want: &[f64], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert_eq!(
            g.to_bits(),
            w.to_bits(),
            "{what}: sample {} {g} vs {w}",
            i + 1
        );
    }
}

/// The one-line message of a refused request.
fn error(file: &str, request: &[&str]) -> String {
    let msg = read_columns(&fixture(file), file, &cols(request))
        .unwrap_err()
        .to_string();
    assert!(!msg.contains('\n'), "not one line: {msg}");
    msg
}

const RECORDS: [&str; 2] = ["record.mat", "record_z.mat"];
const KINDS: [&str; 2] = ["kinds.mat", "kinds_z.mat"];

#[test]
fn record_values_are_bit_exact() {
    let t = expected("t");
    let drive = expected("drive_V");
    let pos = expected("pos_um");
    assert_eq!(t.len(), 200);
    for file in RECORDS {
        let bytes = fixture(file);
        assert!(is_mat(&bytes));
        let got = read_columns(
            &bytes,
            file,
            &cols(&[
                "t",
                "drive_V",
                "pos_um",
                "pos_row",
                "data:1",
                "data:2",
                "data:3",
                "code_i16",
                "code_i32",
                "drive_f32",
                "t:1",
            ]),
        )
        .unwrap();
        assert_bits(&got[0], &t, file);
        assert_bits(&got[1], &drive, file);
        assert_bits(&got[2], &pos, file);
        assert_bits(&got[3], &pos, file);
        assert_bits(&got[4], &t, file);
        assert_bits(&got[5], &drive, file);
        assert_bits(&got[6], &pos, file);
        assert_bits(&got[7], &expected("code_i16"), file);
        assert_bits(&got[8], &expected("code_i32"), file);
        assert_bits(&got[9], &expected("drive_f32"), file);
        assert_bits(&got[10], &t, file);
        // From a reader, as a caller with an open file would.
        let got = read_columns_from(bytes.as_slice(), file, &cols(&["short"])).unwrap();
        assert_bits(&got[0], &drive[..199], file);
    }
    let ok = read_columns(&fixture("kinds_z.mat"), "kinds_z.mat", &cols(&["ok"])).unwrap();
    assert_eq!(ok, [vec![1.0, 2.0, 3.0]]);
}

fn var(name: &str, dims: &[usize], class: MatClass) -> MatVariable {
    MatVariable {
        name: name.into(),
        dims: dims.to_vec(),
        class,
        complex: false,
        logical: false,
    }
}

#[test]
fn variables_are_listed_with_size_and_class() {
    use MatClass::*;
    for file in RECORDS {
        let vars = variables(&fixture(file), file).unwrap();
        let want = [
            var("t", &[200, 1], Double),
            var("drive_V", &[200, 1], Double),
            var("pos_um", &[200, 1], Double),
            var("pos_row", &[1, 200], Double),
            var("data", &[200, 3], Double),
            var("code_i16", &[200, 1], Int16),
            var("code_i32", &[200, 1], Int32),
            var("drive_f32", &[200, 1], Single),
            var("short", &[199, 1], Double),
        ];
        assert_eq!(vars, want, "{file}");
        assert_eq!(vars[0].vector_len(), Some(200));
        assert_eq!(vars[3].vector_len(), Some(200));
        assert_eq!(vars[4].vector_len(), None);
        assert_eq!(vars[4].to_string(), "data (200x3 double)");
    }
    for file in KINDS {
        let vars = variables(&fixture(file), file).unwrap();
        let shown: Vec<String> = vars.iter().map(ToString::to_string).collect();
        assert_eq!(
            shown,
            [
                "ok (3x1 double)",
                "z (2x1 complex double)",
                "label (1x7 char)",
                "params (1x1 struct)",
                "cells (1x2 cell)",
                "sp (3x3 sparse)",
                "flag (3x1 logical)",
                "cube (2x3x4 double)",
                "empty (0x1 double)",
                "bad (10x1 double)",
                "neg_inf (4x1 double)",
            ],
            "{file}"
        );
        assert!(
            vars.iter()
                .all(|v| v.vector_len().is_none() || v.is_real_numeric())
        );
    }
}

#[test]
fn missing_variable_lists_the_file() {
    assert_eq!(
        error("record.mat", &["t", "pos_um2"]),
        "record.mat field 'pos_um2': no variable 'pos_um2' (the file has: t, drive_V, pos_um, \
         pos_row, data, code_i16, code_i32, drive_f32, short)"
    );
}

#[test]
fn v73_is_refused_with_how_to_resave() {
    let bytes = fixture("v73.mat");
    assert!(is_mat(&bytes));
    let msg = error("v73.mat", &["t"]);
    assert_eq!(
        msg,
        "v73.mat: a MATLAB v7.3 MAT-file (HDF5), which fts does not read; re-save it with \
         save(file, '-v7') in MATLAB, or scipy.io.savemat(file, data) in Python"
    );
    // Either sign is enough: the header text, or the HDF5 signature at 512.
    let mut text_only = bytes.clone();
    text_only.truncate(128);
    let mut signature_only = bytes.clone();
    signature_only[..128].fill(b' ');
    for b in [text_only, signature_only] {
        assert!(is_mat(&b));
        let msg = variables(&b, "x.mat").unwrap_err().to_string();
        assert!(msg.contains("MATLAB v7.3 MAT-file (HDF5)"), "{msg}");
    }
}

#[test]
fn v4_and_other_files_are_not_mat_v5() {
    let msg = error("v4.mat", &["t"]);
    assert_eq!(
        msg,
        "v4.mat: not a MAT v5/v7 file (it looks like a MATLAB v4 file); re-save it with \
         save(file, '-v7') in MATLAB, or scipy.io.savemat(file, data) in Python"
    );
    assert!(!is_mat(&fixture("v4.mat")));
    for garbage in [&b""[..], b"t,x\n0,1\n", &fixture("expected.csv")] {
        assert!(!is_mat(garbage));
        let msg = variables(garbage, "x.mat").unwrap_err().to_string();
        assert!(
            msg.starts_with("x.mat: not a MAT v5/v7 file (no MAT-file header)"),
            "{msg}"
        );
    }
}

#[test]
fn non_numeric_classes_are_named() {
    for file in KINDS {
        for (name, says) in [
            (
                "z",
                "'z' is complex (2x1 complex double); a real numeric vector is needed",
            ),
            (
                "label",
                "'label' is a char array (text) (1x7 char); a real numeric vector is needed",
            ),
            (
                "params",
                "'params' is a struct (1x1 struct); a real numeric vector is needed",
            ),
            (
                "cells",
                "'cells' is a cell array (1x2 cell); a real numeric vector is needed",
            ),
            (
                "sp",
                "'sp' is a sparse matrix (3x3 sparse); a real numeric vector is needed",
            ),
            (
                "flag",
                "'flag' is logical (3x1 logical); a real numeric vector is needed",
            ),
        ] {
            let msg = error(file, &[name]);
            assert!(
                msg.starts_with(&format!("{file} field '{name}': {says}")),
                "{msg}"
            );
        }
        assert_eq!(
            error(file, &["ok", "z"]),
            format!(
                "{file} field 'z': 'z' is complex (2x1 complex double); a real numeric vector \
                 is needed (save real(z) or abs(z))"
            )
        );
        assert_eq!(
            error(file, &["params"]),
            format!(
                "{file} field 'params': 'params' is a struct (1x1 struct); a real numeric \
                 vector is needed (save its fields as separate variables)"
            )
        );
    }
}

#[test]
fn shape_and_value_errors() {
    for file in RECORDS {
        assert_eq!(
            error(file, &["data"]),
            format!(
                "{file} field 'data': 'data' is a 200x3 matrix; name one column, 'data:1' to \
                 'data:3' (rows are samples)"
            )
        );
        for k in [0, 4] {
            assert_eq!(
                error(file, &[&format!("data:{k}")]),
                format!(
                    "{file} field 'data:{k}': column {k} out of range: 'data' is a 200x3 \
                     matrix, its columns are 1 to 3"
                )
            );
        }
        assert_eq!(
            error(file, &["t:2"]),
            format!(
                "{file} field 't:2': column 2 out of range: 't' is a vector (200x1), its only \
                 column is 't:1'"
            )
        );
        assert_eq!(
            error(file, &["drive_V", "short"]),
            format!(
                "{file} field 'short': 199 samples, but 'drive_V' has 200; all columns must \
                 have the same length"
            )
        );
    }
    for file in KINDS {
        assert_eq!(
            error(file, &["cube"]),
            format!(
                "{file} field 'cube': 'cube' is a 3-D array (2x3x4); a vector or a 2-D matrix \
                 is needed"
            )
        );
        assert_eq!(
            error(file, &["empty"]),
            format!("{file} field 'empty': 'empty' is empty (0x1)")
        );
        assert_eq!(
            error(file, &["ok", "bad"]),
            format!("{file} field 'bad': sample 6 is NaN; every sample must be finite")
        );
        assert_eq!(
            error(file, &["neg_inf"]),
            format!("{file} field 'neg_inf': sample 3 is -inf; every sample must be finite")
        );
    }
}

// ---------------------------------------------------------------------------
// Robustness.

/// Everything the reader can be asked of `bytes`; must return, never panic.
fn exercise(bytes: &[u8]) {
    let _ = is_mat(bytes);
    if let Ok(vars) = variables(bytes, "fuzz.mat") {
        for v in &vars {
            let _ = v.to_string();
            let _ = read_columns(bytes, "fuzz.mat", &[MatColumn::parse(&v.name)]);
            let _ = read_columns(
                bytes,
                "fuzz.mat",
                &[MatColumn::parse(&format!("{}:2", v.name))],
            );
        }
    }
    let _ = read_columns(bytes, "fuzz.mat", &cols(&["t", "data:3", "z", "missing"]));
}

/// The top-level elements of a valid uncompressed fixture (tag included).
fn elements(file: &[u8]) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    let mut pos = 128;
    while pos + 8 <= file.len() {
        let size = u32::from_le_bytes(file[pos + 4..pos + 8].try_into().unwrap()) as usize;
        let end = pos + 8 + size.div_ceil(8) * 8;
        out.push(file[pos..end].to_vec());
        pos = end;
    }
    out
}

/// A file of compressed elements, as MATLAB's `-v7` writes.
fn compressed_file(header: &[u8], elements: &[Vec<u8>]) -> Vec<u8> {
    let mut out = header[..128].to_vec();
    for e in elements {
        let mut enc = libflate::zlib::Encoder::new(Vec::new()).unwrap();
        enc.write_all(e).unwrap();
        let stream = enc.finish().into_result().unwrap();
        out.extend_from_slice(&15u32.to_le_bytes());
        out.extend_from_slice(&(stream.len() as u32).to_le_bytes());
        out.extend(stream);
    }
    out
}

fn mutate(mut bytes: Vec<u8>, edits: &[(usize, u8)]) -> Vec<u8> {
    if !bytes.is_empty() {
        for &(at, v) in edits {
            let n = bytes.len();
            bytes[at % n] = v;
        }
    }
    bytes
}

fn fixtures() -> [Vec<u8>; 4] {
    ["record.mat", "record_z.mat", "kinds.mat", "kinds_z.mat"].map(fixture)
}

proptest! {
    #![proptest_config(config(256))]

    #[test]
    fn random_bytes(bytes in prop::collection::vec(any::<u8>(), 0..1500), header in any::<bool>()) {
        let bytes = if header {
            let mut b = fixture("kinds.mat")[..128].to_vec();
            b.extend(bytes);
            b
        } else {
            bytes
        };
        exercise(&bytes);
    }

    #[test]
    fn truncated_fixtures(which in 0usize..4, cut in any::<prop::sample::Index>()) {
        let file = &fixtures()[which];
        exercise(&file[..cut.index(file.len() + 1)]);
    }

    #[test]
    fn mutated_fixtures(
        which in 0usize..4,
        edits in prop::collection::vec((any::<usize>(), any::<u8>()), 1..8),
        near_tags in any::<bool>(),
    ) {
        let file = fixtures()[which].clone();
        // Half of the cases hit the first 600 bytes, where the headers and tags are dense.
        let edits: Vec<(usize, u8)> = if near_tags {
            edits.iter().map(|&(at, v)| (at % 600, v)).collect()
        } else {
            edits
        };
        exercise(&mutate(file, &edits));
    }

    #[test]
    fn mutated_then_compressed(
        which in prop::sample::select(vec!["record.mat", "kinds.mat"]),
        edits in prop::collection::vec((any::<usize>(), any::<u8>()), 1..6),
        target in any::<prop::sample::Index>(),
        keep in any::<prop::sample::Index>(),
    ) {
        // Compressed variables whose content is damaged but whose zlib
        // stream is valid, so the parser behind the inflation is reached.
        let file = fixture(which);
        let mut elements = elements(&file);
        let i = target.index(elements.len());
        let edits: Vec<(usize, u8)> = edits.iter().map(|&(at, v)| (at % 96, v)).collect();
        elements[i] = mutate(std::mem::take(&mut elements[i]), &edits);
        let keep = keep.index(elements[i].len() + 1);
        elements[i].truncate(keep.max(1));
        exercise(&compressed_file(&file, &elements));
    }
}

#[test]
fn compressed_copy_reads_like_the_original() {
    // The test helper above builds valid compressed files.
    let file = fixture("record.mat");
    let z = compressed_file(&file, &elements(&file));
    let request = cols(&["t", "data:2", "code_i32"]);
    assert_eq!(
        read_columns(&z, "z.mat", &request).unwrap(),
        read_columns(&file, "record.mat", &request).unwrap()
    );
}

#[test]
fn crafted_sizes_allocate_little() {
    const LIMIT: usize = 1 << 20;
    let header = &fixture("kinds.mat")[..128];
    let ok = &elements(&fixture("kinds.mat"))[0];
    // 1. A top-level element declaring 4 GiB.
    let mut huge = header.to_vec();
    huge.extend_from_slice(&14u32.to_le_bytes());
    huge.extend_from_slice(&u32::MAX.to_le_bytes());
    huge.extend_from_slice(&ok[8..]);
    // 2. A compressed element whose matrix tag declares ~4 GiB.
    let mut inner = ok.clone();
    inner[4..8].copy_from_slice(&0xFFFF_FF00u32.to_le_bytes());
    let claims = compressed_file(header, &[inner]);
    // 3. A real zlib bomb: 64 MiB of zeros behind a matrix tag, listed only.
    let mut bomb = 14u32.to_le_bytes().to_vec();
    bomb.extend_from_slice(&(64u32 << 20).to_le_bytes());
    bomb.extend_from_slice(&ok[8..]);
    bomb.resize(8 + (64 << 20), 0);
    let bomb = compressed_file(header, &[bomb]);
    assert!(bomb.len() < 200_000);
    // 4. Dimensions of 2^31 - 1 squared over one value.
    let mut dims = ok.clone();
    dims[32..40].copy_from_slice(&[0xFF, 0xFF, 0xFF, 0x7F, 0xFF, 0xFF, 0xFF, 0x7F]);
    let mut dims_file = header.to_vec();
    dims_file.extend(dims);

    for (what, bytes) in [("huge", &huge), ("claims", &claims), ("dims", &dims_file)] {
        LARGEST.with(|c| c.set(0));
        let _ = variables(bytes, "x.mat");
        let _ = read_columns(bytes, "x.mat", &cols(&["ok"]));
        let largest = LARGEST.with(Cell::get);
        assert!(largest < LIMIT, "{what}: an allocation of {largest} bytes");
    }
    LARGEST.with(|c| c.set(0));
    let vars = variables(&bomb, "bomb.mat").unwrap();
    assert_eq!(vars[0].name, "ok");
    let largest = LARGEST.with(Cell::get);
    assert!(
        largest < LIMIT,
        "listing the bomb: an allocation of {largest} bytes"
    );
}
