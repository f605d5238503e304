use super::*;
use std::path::{Path, PathBuf};

fn validation_dir() -> Option<PathBuf> {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/validation");
    if d.is_dir() {
        Some(d)
    } else {
        println!("SKIP: {} absent", d.display());
        None
    }
}

/// A fresh temporary file, removed (with its folder) when dropped.
fn tmp(name: &str) -> crate::test_dir::TempFile {
    crate::test_dir::TempFile::new("storage", name)
}

fn write_text(name: &str, text: &str) -> crate::test_dir::TempFile {
    let p = tmp(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn c_fixed_matches_printf() {
    // Expected strings are what C printf("%16.8f") / glibc prints; checked with
    // Python's '%16.8f' % x, which follows C's rules (exact value, round half even).
    assert_eq!(format_c_fixed(0.59999926, 16, 8), "      0.59999926");
    assert_eq!(format_c_fixed(-1e-12, 16, 8), "     -0.00000000");
    assert_eq!(format_c_fixed(-0.0, 16, 8), "     -0.00000000");
    assert_eq!(format_c_fixed(0.0, 16, 8), "      0.00000000");
    assert_eq!(format_c_fixed(0.125, 6, 2), "  0.12"); // exact tie -> even
    assert_eq!(format_c_fixed(0.375, 6, 2), "  0.38");
    assert_eq!(format_c_fixed(2.5, 3, 0), "  2");
    assert_eq!(format_c_fixed(0.045, 0, 2), "0.04"); // 0.045 is below the tie in binary
    assert_eq!(format_c_fixed(f64::NAN, 16, 8), "             nan");
    assert_eq!(format_c_fixed(-f64::NAN, 6, 2), "  -nan");
    assert_eq!(format_c_fixed(f64::INFINITY, 16, 8), "             inf");
    assert_eq!(format_c_fixed(f64::NEG_INFINITY, 16, 8), "            -inf");
    // wider than the field: no truncation
    assert_eq!(format_c_fixed(123456789.5, 4, 1), "123456789.5");
    assert_eq!(format_c_fixed(0.1, 28, 20), "      0.10000000000000000555");
}

/// Re-write OpenSim 4.6's ID output (printed with output_precision 20) and
/// compare the files line by line. The only difference allowed is the
/// padding after the `nRows=` number (our streaming writer reserves a fixed
/// width for it), so that one line is compared with trailing spaces removed.
#[test]
fn rewrite_matches_opensim_byte_for_byte() {
    let Some(v) = validation_dir() else { return };
    let src = v.join("arm26/results/arm26_ID_generalized_forces.sto");
    let st = read(&src).unwrap();
    assert_eq!(st.name, "Inverse Dynamics Generalized Forces");
    assert_eq!(st.len(), 121);
    let out = tmp("id_rewrite.sto");
    write(&out, &st, 20).unwrap();
    let want = std::fs::read_to_string(&src).unwrap();
    let got = std::fs::read_to_string(&out).unwrap();
    let (w, g): (Vec<&str>, Vec<&str>) = (want.lines().collect(), got.lines().collect());
    assert_eq!(w.len(), g.len());
    let mut data_lines = 0;
    for (i, (a, b)) in w.iter().zip(&g).enumerate() {
        if a.starts_with("nRows=") {
            assert_eq!(*a, b.trim_end(), "line {}", i + 1);
            assert_ne!(*a, *b, "nRows should be padded");
        } else {
            assert_eq!(a, b, "line {}", i + 1);
            if i > 6 {
                data_lines += 1;
            }
        }
    }
    assert_eq!(data_lines, 121);
    assert_eq!(want.len() + (g[2].len() - w[2].len()), got.len());
}

#[test]
fn round_trip_exact_at_precision_20_and_close_at_8() {
    let st = Storage {
        name: "Round trip".into(),
        labels: vec!["a".into(), "b_tx".into(), "c".into()],
        time: vec![-0.5, 0.0, 0.1, 0.30000000000000004],
        rows: vec![
            vec![1.0, -2.5, std::f64::consts::PI],
            vec![0.001234567890123, 987.6543210987654, -0.1],
            vec![-123.456, 0.3333333333333333, 42.0],
            vec![0.5, -0.007, 1.0 / 7.0],
        ],
        in_degrees: true,
        metadata: vec![
            ("DataRate".into(), "60".into()),
            ("header".into(), "line one\nline two".into()),
        ],
    };
    let p = tmp("rt20.sto");
    write(&p, &st, 20).unwrap();
    let back = read(&p).unwrap();
    // 20 decimals give >= 17 significant digits for |x| >= 1e-3: bitwise round trip.
    assert_eq!(back, st);

    let p8 = tmp("rt8.mot");
    write(&p8, &st, 8).unwrap();
    let b8 = read(&p8).unwrap();
    assert_eq!(b8.labels, st.labels);
    assert!(b8.in_degrees);
    for (r, s) in b8.rows.iter().zip(&st.rows) {
        for (x, y) in r.iter().zip(s) {
            assert!((x - y).abs() <= 5e-9, "{x} vs {y}");
        }
    }
    assert_eq!(b8.column_index("c"), Some(2));
    assert_eq!(b8.column_index("time"), None);
    assert_eq!(b8.column(1), vec![-2.5, 987.65432110, 0.33333333, -0.007]);
}

#[test]
fn streaming_file_is_valid_after_every_row() {
    let p = tmp("stream.sto");
    let labels = vec!["x".to_string(), "y".to_string()];
    let mut w = StoWriter::create(&p, "Streaming", "\nsome text\n\n", &labels, 8, false).unwrap();
    let r0 = read(&p).unwrap();
    assert_eq!(r0.len(), 0);
    for i in 0..5 {
        w.write_row(i as f64 * 0.1, &[i as f64, -(i as f64)])
            .unwrap();
        // Read without finishing, as if the process were killed now.
        let r = read(&p).unwrap();
        assert_eq!(r.len(), i + 1);
        assert_eq!(r.rows[i], vec![i as f64, -(i as f64)]);
    }
    assert!(w.write_row(1.0, &[1.0]).is_err());
    drop(w);
    // A half-written row after the counted rows is ignored, as OpenSim does.
    let mut text = std::fs::read_to_string(&p).unwrap();
    assert!(text.contains("nRows=5           \n"));
    text.push_str("      0.50000000\t    1.0");
    std::fs::write(&p, &text).unwrap();
    let r = read(&p).unwrap();
    assert_eq!(r.len(), 5);
    assert_eq!(r.meta("header"), Some("some text"));
}

#[test]
fn batched_rows_reach_the_file_batch_by_batch() {
    let p = tmp("batched.sto");
    let labels = vec!["x".to_string()];
    let mut w = StoWriter::create(&p, "Batched", "", &labels, 8, false).unwrap();
    w.batch_rows(4, std::time::Duration::from_secs(3600));
    for i in 0..10 {
        w.write_row(i as f64, &[2.0 * i as f64]).unwrap();
        // Only whole batches are on disk, and the file is always valid.
        let r = read(&p).unwrap();
        assert_eq!(r.len(), (i + 1) / 4 * 4, "after row {i}");
        assert_eq!(w.rows_written(), i + 1);
    }
    w.finish().unwrap();
    let r = read(&p).unwrap();
    assert_eq!(r.len(), 10);
    assert_eq!(r.rows[9], vec![18.0]);

    // A writer dropped without finish (a run stopped by an error) writes
    // its pending rows; with max_age zero every row is written at once.
    let mut w = StoWriter::create(&p, "Batched", "", &labels, 8, false).unwrap();
    w.batch_rows(100, std::time::Duration::ZERO);
    w.write_row(0.0, &[1.0]).unwrap();
    assert_eq!(read(&p).unwrap().len(), 1);
    w.batch_rows(100, std::time::Duration::from_secs(3600));
    w.write_row(1.0, &[2.0]).unwrap();
    w.write_row(2.0, &[3.0]).unwrap();
    assert_eq!(read(&p).unwrap().len(), 1);
    drop(w);
    let r = read(&p).unwrap();
    assert_eq!(r.len(), 3);
    assert_eq!(r.rows[2], vec![3.0]);
}

#[test]
fn writer_rejects_labels_with_spaces() {
    let p = tmp("badlabel.sto");
    let e = StoWriter::create(&p, "n", "", &["a b".to_string()], 8, false);
    assert!(e.is_err());
}

#[test]
fn reads_every_validation_table() {
    let Some(v) = validation_dir() else { return };
    let mut files = Vec::new();
    let mut stack = vec![v];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("sto") | Some("mot")
            ) {
                files.push(p);
            }
        }
    }
    assert!(files.len() > 10);
    for f in &files {
        let st = read(f).unwrap_or_else(|e| panic!("{e}"));
        let text = std::fs::read_to_string(f).unwrap();
        let nrows: usize = text
            .lines()
            .find_map(|l| l.trim().strip_prefix("nRows="))
            .unwrap()
            .trim()
            .parse()
            .unwrap();
        let ncols: usize = text
            .lines()
            .find_map(|l| l.trim().strip_prefix("nColumns="))
            .unwrap()
            .trim()
            .parse()
            .unwrap();
        assert_eq!(st.len(), nrows, "{}", f.display());
        assert_eq!(st.labels.len() + 1, ncols, "{}", f.display());
        assert!(st.rows.iter().all(|r| r.len() == st.labels.len()));
    }
    println!("read {} files", files.len());
    let ik = read(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/validation/arm26/inputs/arm26_InverseKinematics.mot"),
    )
    .unwrap();
    assert!(ik.in_degrees);
    assert_eq!(ik.name, "Coordinates");
    assert_eq!(ik.labels, ["r_shoulder_elev", "r_elbow_flex"]);
    assert_eq!(ik.time[1], 0.00833333);
    assert_eq!(ik.rows[0], vec![-0.03394423, -0.05440752]);
}

#[test]
fn version0_mot_is_in_degrees_even_if_it_says_radians() {
    let text =
        "motion\nnRows=2\nnColumns=2\nAngles are in radians.\nendheader\ntime q\n0 1\n0.5 2\n";
    let st = read(&write_text("v0.mot", text)).unwrap();
    assert!(st.in_degrees);
    assert_eq!(st.name, "motion");
    let st = read(&write_text("v0.sto", text)).unwrap();
    assert!(!st.in_degrees);
    let st = read(&write_text(
        "v0deg.sto",
        &text.replace("radians", "degrees"),
    ))
    .unwrap();
    assert!(st.in_degrees);
    assert_eq!(st.time, vec![0.0, 0.5]);
}

#[test]
fn reads_time_series_table_v3() {
    // Layout as written by OpenSim 4.6's STOFileAdapter (§1.4).
    let text = "inDegrees=yes\nDataType=double\nversion=3\nOpenSimVersion=4.6\nendheader\ntime\tq1\tq2\n0.1\t3.123456789012345\t4\n0.2\t1\t2\n\n9\t9\t9\n";
    let st = read(&write_text("v3.sto", text)).unwrap();
    assert!(st.in_degrees);
    assert_eq!(st.labels, ["q1", "q2"]);
    assert_eq!(st.rows, vec![vec![3.123456789012345, 4.0], vec![1.0, 2.0]]);

    let vec3 = "DataType=Vec3\nversion=3\nendheader\ntime\tm\n0\t1,2,3\n1\t4,5,6\n";
    let st = read(&write_text("v3vec.sto", vec3)).unwrap();
    assert_eq!(st.labels, ["m_x", "m_y", "m_z"]);
    assert_eq!(st.rows[1], vec![4.0, 5.0, 6.0]);

    let bad = "version=3\nendheader\nt\tq\n0\t1\n";
    let e = read(&write_text("v3bad.sto", bad)).unwrap_err().to_string();
    assert!(e.contains("'time'") && e.contains("line 3"), "{e}");
    let spaces = "version=3\nendheader\ntime q\n0 1\n";
    assert!(read(&write_text("v3sp.sto", spaces)).is_err());
}

fn err_of(name: &str, text: &str) -> String {
    let e = read(&write_text(name, text)).unwrap_err();
    assert_eq!(e.exit_code(), 2);
    e.to_string()
}

/// The error the streaming row reader gives on `text`.
fn read_stream_err(name: &str, text: &str) -> String {
    let mut r = super::read::open_rows(&write_text(name, text)).unwrap();
    let mut row = Vec::new();
    loop {
        match r.next_row(&mut row) {
            Ok(Some(_)) => continue,
            Ok(None) => panic!("{name}: read without error"),
            Err(e) => return e.to_string(),
        }
    }
}

const HEAD: &str = "test\nversion=1\nnRows=3\nnColumns=3\ninDegrees=no\nendheader\ntime\ta\tb\n";

#[test]
fn input_errors_name_file_line_and_column() {
    let e = read(Path::new("/nonexistent/dir/x.sto"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("/nonexistent/dir/x.sto"), "{e}");

    let e = err_of(
        "noend.sto",
        "test\nversion=1\nnRows=1\nnColumns=2\ntime a\n0 1\n",
    );
    assert!(e.contains("endheader") && e.contains("noend.sto"), "{e}");

    let e = err_of("few.sto", &format!("{HEAD}0 1 2\n0.1 1\n0.2 1 2\n"));
    assert!(e.contains("line 9") && e.contains("column 'b'"), "{e}");

    // An empty cell in a tab-separated row names its own column (it blamed
    // the last column before: the values shifted left).
    let e = err_of(
        "empty.sto",
        &format!("{HEAD}0\t1\t2\n0.1\t\t2\n0.2\t1\t2\n"),
    );
    assert!(
        e.contains("line 9") && e.contains("column 'a'") && e.contains("empty cell"),
        "{e}"
    );
    assert!(read_stream_err(
        "empty_stream.sto",
        &format!("{HEAD}0\t1\t2\n0.1\t\t2\n0.2\t1\t2\n")
    )
    .contains("column 'a'"));

    let e = err_of("word.sto", &format!("{HEAD}0 1 2\n0.1 1 abc\n0.2 1 2\n"));
    assert!(
        e.contains("line 9") && e.contains("column 'b'") && e.contains("abc"),
        "{e}"
    );

    let e = err_of("nan.sto", &format!("{HEAD}0 1 2\n0.1 NaN 2\n0.2 1 2\n"));
    assert!(
        e.contains("line 9") && e.contains("column 'a'") && e.contains("NaN"),
        "{e}"
    );

    let e = err_of("inf.sto", &format!("{HEAD}0 1 2\n0.1 1 2\n0.2 1 -inf\n"));
    assert!(e.contains("line 10") && e.contains("column 'b'"), "{e}");

    let e = err_of("time.sto", &format!("{HEAD}0 1 2\n0.1 1 2\n0.1 1 2\n"));
    assert!(e.contains("line 10") && e.contains("column 'time'"), "{e}");

    let e = err_of("short.sto", &format!("{HEAD}0 1 2\n0.1 1 2\n"));
    assert!(e.contains("nRows=3"), "{e}");

    let e = err_of(
        "ncol.sto",
        "x\nnRows=1\nnColumns=4\nendheader\ntime a b\n0 1 2\n",
    );
    assert!(e.contains("nColumns=4") && e.contains("line 5"), "{e}");
}

/// The row reader yields exactly what `read` loads, for every table of the
/// validation cases, and reports the same errors on bad rows.
#[test]
fn row_reader_equals_read() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/validation");
    if !root.is_dir() {
        println!("SKIP: {} absent", root.display());
        return;
    }
    let mut n = 0;
    for case in ["arm26", "leg6dof9musc_stance", "gait10dof18musc_walk"] {
        for dir in [
            root.join(case).join("inputs"),
            root.join(case).join("results"),
        ] {
            let Ok(entries) = std::fs::read_dir(&dir) else {
                continue;
            };
            for e in entries.flatten() {
                let p = e.path();
                let ext = p.extension().and_then(|x| x.to_str()).unwrap_or("");
                if ext != "sto" && ext != "mot" {
                    continue;
                }
                let whole = crate::storage::read(&p).unwrap();
                let mut r = crate::storage::open_rows(&p).unwrap();
                assert_eq!(r.table.labels, whole.labels, "{}", p.display());
                assert_eq!(r.table.in_degrees, whole.in_degrees);
                let mut row = Vec::new();
                let mut i = 0;
                while let Some(t) = r.next_row(&mut row).unwrap() {
                    assert_eq!(t, whole.time[i]);
                    assert_eq!(row, whole.rows[i]);
                    i += 1;
                }
                assert_eq!(i, whole.len(), "{}", p.display());
                n += 1;
            }
        }
    }
    assert!(n >= 6, "{n} files");
    println!("row reader equals read on {n} files");
}

/// TimeSeriesTable files (version ≥ 2) are read row by row, not whole:
/// the rows `read` loads (double, Vec3 and SpatialVec columns, up to the
/// first empty line), and a mark taken mid-file returns to the same row.
#[test]
fn row_reader_streams_time_series_tables() {
    let tmp = crate::test_dir::TempDir::new("statopt-rowreader-v3");
    let dir = tmp.path().to_path_buf();
    let mut cases = Vec::new();
    for (name, data_type, cell) in [
        ("double.sto", "double", "{a}"),
        ("vec3.sto", "Vec3", "{a},{b},-{a}"),
        ("spatial.sto", "SpatialVec", "{a},{b},1,2,3,{a}"),
    ] {
        let mut text = format!("name\nversion=3\nDataType={data_type}\nendheader\ntime\tp\tq\n");
        for i in 0..300 {
            let (a, b) = (0.25 * i as f64, 1.0 - 0.125 * i as f64);
            let c = cell
                .replace("{a}", &a.to_string())
                .replace("{b}", &b.to_string());
            text.push_str(&format!("{}\t{c}\t{c}\n", 0.01 * i as f64));
        }
        // rows after the first empty line are not data
        text.push_str("\n9\tnot\tdata\n");
        cases.push((name, text));
    }
    for (name, text) in cases {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        let whole = crate::storage::read(&p).unwrap();
        assert_eq!(whole.len(), 300, "{name}");
        let mut r = crate::storage::open_rows(&p).unwrap();
        assert_eq!(r.table.labels, whole.labels, "{name}");
        let mut row = Vec::new();
        let mut marks = Vec::new();
        let mut i = 0;
        loop {
            if i % 100 == 0 {
                marks.push((i, r.mark()));
            }
            let Some(t) = r.next_row(&mut row).unwrap() else {
                break;
            };
            assert_eq!((t, &row), (whole.time[i], &whole.rows[i]), "{name} row {i}");
            i += 1;
        }
        assert_eq!(i, 300, "{name}");
        assert!(r.next_row(&mut row).unwrap().is_none());
        r.seek_row(150, &marks).unwrap();
        assert_eq!(
            r.next_row(&mut row).unwrap(),
            Some(whole.time[150]),
            "{name}"
        );
        assert_eq!(row, whole.rows[150]);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn row_reader_errors_like_read() {
    let tmp = crate::test_dir::TempDir::new("statopt-rowreader");
    let dir = tmp.path().to_path_buf();
    for (name, text) in [
        (
            "short.sto",
            "x\nversion=1\nnRows=3\nnColumns=2\nendheader\ntime a\n0 1\n1 2\n",
        ),
        (
            "back.sto",
            "x\nversion=1\nnRows=3\nnColumns=2\nendheader\ntime a\n0 1\n1 2\n0.5 3\n",
        ),
        (
            "bad.sto",
            "x\nversion=1\nnRows=2\nnColumns=2\nendheader\ntime a\n0 1\n1 zz\n",
        ),
        (
            "cols.sto",
            "x\nversion=1\nnRows=2\nnColumns=2\nendheader\ntime a\n0 1 3\n1 2\n",
        ),
        // TimeSeriesTable files (read row by row too)
        (
            "v3back.sto",
            "version=3\nendheader\ntime\ta\n0\t1\n1\t2\n0.5\t3\n",
        ),
        (
            "v3bad.sto",
            "version=3\nDataType=Vec3\nendheader\ntime\tp\n0\t1,2,3\n1\t1,zz,3\n",
        ),
        (
            "v3comps.sto",
            "version=3\nDataType=Vec3\nendheader\ntime\tp\n0\t1,2,3\n1\t1,2\n",
        ),
        (
            "v3cols.sto",
            "version=3\nendheader\ntime\ta\tb\n0\t1\t2\n1\t2\n",
        ),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        let want = crate::storage::read(&p).unwrap_err().to_string();
        let mut r = crate::storage::open_rows(&p).unwrap();
        let mut row = Vec::new();
        let got = loop {
            match r.next_row(&mut row) {
                Ok(Some(_)) => continue,
                Ok(None) => panic!("{name}: no error"),
                Err(e) => break e.to_string(),
            }
        };
        assert_eq!(got, want, "{name}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Frame times in messages read as the motion's row times, not as the
/// float noise of a time computed on its grid.
#[test]
fn frame_times_print_without_float_noise() {
    use super::fmt_time;
    assert_eq!(fmt_time(0.5833328799999886), "0.58333288");
    assert_eq!(fmt_time(2.4999984999999625), "2.4999985");
    assert_eq!(fmt_time(1.31), "1.31");
    assert_eq!(fmt_time(2.0), "2");
    assert_eq!(fmt_time(-0.0000000001), "0");
    assert_eq!(fmt_time(-0.25), "-0.25");
}

/// A [`TableFile`] read once into memory is one opening of the file; its
/// readers (whole and row by row, with seeks) then give what reading the
/// file gives, errors included, and do not open the file again. Above the
/// size limit it stays on the disk and each reader opens the file.
#[test]
fn table_file_in_memory_reads_as_the_file() {
    let tmp = crate::test_dir::TempDir::new("statopt-tablefile");
    let dir = tmp.path().to_path_buf();
    let good = dir.join("good.mot");
    std::fs::write(
        &good,
        "m\nversion=1\nnRows=4\nnColumns=3\ninDegrees=yes\nendheader\ntime\ta\tb\n\
         0\t1\t2\n0.1\t3\t4\n0.2\t5\t6.5\n0.3\t7\t8\n",
    )
    .unwrap();
    let file = TableFile::read(&good).unwrap();
    assert!(file.in_memory());
    assert_eq!(times_opened(&good), 1);
    let whole = read(&good).unwrap();
    assert_eq!(times_opened(&good), 2);
    assert_eq!(read_file(&file).unwrap(), whole);
    let mut r = open_rows_in(&file).unwrap();
    let mut row = Vec::new();
    let mut marks = Vec::new();
    let mut i = 0;
    loop {
        marks.push(r.mark());
        let Some(t) = r.next_row(&mut row).unwrap() else {
            break;
        };
        assert_eq!((t, &row), (whole.time[i], &whole.rows[i]));
        i += 1;
    }
    assert_eq!(i, 4);
    r.seek(&marks[2]).unwrap();
    assert_eq!(r.next_row(&mut row).unwrap(), Some(0.2));
    assert_eq!(row, whole.rows[2]);
    assert_eq!(
        times_opened(&good),
        2,
        "the bytes in memory are not the file"
    );

    let bad = dir.join("bad.sto");
    std::fs::write(
        &bad,
        "x\nversion=1\nnRows=2\nnColumns=2\nendheader\ntime a\n0 1\n1 zz\n",
    )
    .unwrap();
    let want = read(&bad).unwrap_err().to_string();
    let file = TableFile::read(&bad).unwrap();
    assert_eq!(read_file(&file).unwrap_err().to_string(), want);
    let mut r = open_rows_in(&file).unwrap();
    let got = loop {
        match r.next_row(&mut row) {
            Ok(Some(_)) => continue,
            Ok(None) => panic!("no error"),
            Err(e) => break e.to_string(),
        }
    };
    assert_eq!(got, want);
    assert!(
        want.contains("bad.sto") && want.contains("line 8"),
        "{want}"
    );

    let big = TableFile::read_up_to(&good, 10).unwrap();
    assert!(!big.in_memory());
    let before = times_opened(&good);
    assert_eq!(read_file(&big).unwrap(), whole);
    open_rows_in(&big).unwrap();
    assert_eq!(times_opened(&good), before + 2);

    let missing = dir.join("missing.mot");
    assert_eq!(
        TableFile::read(&missing).unwrap_err().to_string(),
        read(&missing).unwrap_err().to_string()
    );
}

/// An output file is replaced by a new one (a new inode: no truncation in
/// place), but one reached through a symbolic link or holding other hard
/// links is written in place, so the link's target gets the output.
#[cfg(unix)]
#[test]
fn create_output_replaces_files_and_keeps_links() {
    use std::io::Write;
    use std::os::unix::fs::MetadataExt;
    let dir = crate::test_dir::TempDir::new("storage-create-output");
    let d = dir.path();
    let read = |p: &Path| std::fs::read_to_string(p).unwrap();

    let plain = d.join("plain.sto");
    std::fs::write(&plain, "old contents, longer than the new").unwrap();
    // A reader of the old file still reads it whole: it was not truncated.
    let mut old = std::fs::File::open(&plain).unwrap();
    create_output(&plain).unwrap().write_all(b"new").unwrap();
    assert_eq!(read(&plain), "new");
    let mut kept = String::new();
    std::io::Read::read_to_string(&mut old, &mut kept).unwrap();
    assert_eq!(kept, "old contents, longer than the new");
    assert_ne!(
        std::fs::metadata(&plain).unwrap().ino(),
        old.metadata().unwrap().ino()
    );

    let target = d.join("target.sto");
    let link = d.join("link.sto");
    std::fs::write(&target, "old target").unwrap();
    std::os::unix::fs::symlink(&target, &link).unwrap();
    create_output(&link).unwrap().write_all(b"through").unwrap();
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(read(&target), "through");

    let first = d.join("first.sto");
    let second = d.join("second.sto");
    std::fs::write(&first, "old linked").unwrap();
    std::fs::hard_link(&first, &second).unwrap();
    create_output(&first).unwrap().write_all(b"both").unwrap();
    assert_eq!(read(&second), "both");

    let fresh = d.join("fresh.sto");
    create_output(&fresh).unwrap().write_all(b"made").unwrap();
    assert_eq!(read(&fresh), "made");
}

/// Rows read from a file's bytes in memory (`TableFile::read`), and rows
/// parsed ahead (`TableFile::parse_rows_ahead`), are the rows read from the
/// disk, line numbers, errors and positions included: a blank line, a token
/// off the fast path and a bad row midway, CR line ends, and seeking back.
#[test]
fn rows_read_from_memory_are_the_files_rows() {
    rows_from_memory_are_the_files_rows(false);
    rows_from_memory_are_the_files_rows(true);
}

fn rows_from_memory_are_the_files_rows(ahead: bool) {
    let tmp = crate::test_dir::TempDir::new("statopt-rows-in-memory");
    let path = tmp.path().join("m.sto");
    let mut text = String::from("m\r\nversion=1\r\nnColumns=3\r\n endheader \r\ntime\ta\tb\r\n");
    for i in 0..40 {
        let t = i as f64 * 0.01;
        match i {
            12 => text.push_str("\r\n"),
            20 => text.push_str(&format!("{t}\t1e-3\t-2.5\r\n")),
            33 => text.push_str(&format!("{t}\t7\r\n")), // a value missing
            _ => text.push_str(&format!("{t}\t{}\t-{}.0625\r\n", i * 3, i)),
        }
    }
    std::fs::write(&path, &text).unwrap();
    let file = TableFile::read(&path).unwrap();
    assert!(file.in_memory());
    if ahead {
        // Parsed on another thread, seen by a clone made before.
        let clone = file.clone();
        std::thread::scope(|s| s.spawn(|| clone.parse_rows_ahead()).join().unwrap());
        let rows = file
            .parsed_rows()
            .expect("a small file's rows are parsed ahead");
        // Rows 0..12 precede the blank line, where parsing ahead stops.
        assert_eq!((rows.columns(), rows.find(rows.end(11), 0)), (2, None));
        assert!(rows.find(rows.end(10), 11) == Some(11));
    } else {
        assert!(file.parsed_rows().is_none());
    }
    let mut own = open_rows_in(&TableFile::on_disk(&path)).unwrap();
    let mut fast = open_rows_in(&file).unwrap();
    let (mut a, mut b) = (Vec::new(), Vec::new());
    let mut marks = Vec::new();
    loop {
        marks.push((own.mark(), fast.mark()));
        let x = own.next_row(&mut a).map_err(|e| e.to_string());
        let y = fast.next_row(&mut b).map_err(|e| e.to_string());
        assert_eq!(x, y);
        let Ok(Some(_)) = x else {
            assert!(x.unwrap_err().contains("line 39"));
            break;
        };
        assert_eq!(a, b);
        assert_eq!(own.count(), fast.count());
    }
    // Back to row 5 and on from there.
    own.seek(&marks[5].0).unwrap();
    fast.seek(&marks[5].1).unwrap();
    for _ in 0..10 {
        assert_eq!(
            own.next_row(&mut a).unwrap(),
            fast.next_row(&mut b).unwrap()
        );
        assert_eq!(a, b);
    }
}
