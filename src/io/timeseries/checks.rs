use super::*;

fn io(text: &str, cols: &IoColumns) -> Result<IoData, InputError> {
    read_io(text.as_bytes(), "f.csv", cols, 1)
}

fn with_layout(layout: Layout) -> IoColumns {
    IoColumns {
        layout,
        ..Default::default()
    }
}

pub fn header_names_and_time() {
    let d = io(
        "# comment\nt,u,y\n0,1,2\n0.5,3,4\n1.0,5,6\n",
        &IoColumns::default(),
    )
    .unwrap();
    assert_eq!(d.input, vec![1.0, 3.0, 5.0]);
    assert_eq!(d.output, vec![2.0, 4.0, 6.0]);
    assert_eq!(d.ts, Some(0.5));
    let t = d.timing.unwrap();
    assert_eq!(
        (t.unit, t.unit_from),
        (TimeUnit::Seconds, UnitSource::Default)
    );
    assert_eq!(t.max_jitter, 0.0);
}

pub fn whitespace_dat_headerless_defaults() {
    let d = io(
        "   6.41e+00\t   4.76e+00\t\n   3.41e+00\t 4.70e+00\t\n",
        &IoColumns::default(),
    )
    .unwrap();
    assert_eq!(d.input, vec![6.41, 3.41]);
    assert_eq!(d.output, vec![4.76, 4.70]);
    assert_eq!(d.ts, None);
}

pub fn empty_leading_field_counts_as_column_one() {
    let cols = IoColumns {
        input: Some(ColumnRef::Index(4)),
        output: Some(ColumnRef::Index(3)),
        ..Default::default()
    };
    let d = io(",0,-1.6,0\n,0.0002,-1.7,5\n", &cols).unwrap();
    assert_eq!(d.input, vec![0.0, 5.0]);
    assert_eq!(d.output, vec![-1.6, -1.7]);
}

pub fn errors_name_line_and_field() {
    let e = io("u,y\n1,2\n3,abc\n", &IoColumns::default()).unwrap_err();
    assert_eq!(e.line, Some(3));
    assert_eq!(e.field.as_deref(), Some("y"));
    assert!(e.to_string().contains("not a number"), "{e}");

    let e = io("u,y\n1,\n", &IoColumns::default()).unwrap_err();
    assert!(e.to_string().contains("empty cell"), "{e}");

    let e = io("u,y\n1,NaN\n", &IoColumns::default()).unwrap_err();
    assert!(e.to_string().contains("finite"), "{e}");

    let e = io("a,b\n1,2\n", &IoColumns::default()).unwrap_err();
    assert!(e.to_string().contains("missing column 'u'"), "{e}");
    assert_eq!(e.line, Some(1));

    let e = io("t,u,y\n0,1,2\n0,1,2\n", &IoColumns::default()).unwrap_err();
    assert!(e.to_string().contains("time must increase"), "{e}");
    assert_eq!(e.line, Some(3));

    let e = read_io("u,y\n1,2\n".as_bytes(), "f.csv", &IoColumns::default(), 5).unwrap_err();
    assert!(
        e.to_string()
            .contains("too few data rows: 1 found, at least 5"),
        "{e}"
    );

    let e = io("1 2\n3\n", &IoColumns::default()).unwrap_err();
    assert_eq!(e.line, Some(2));
    assert!(e.to_string().contains("missing field"), "{e}");

    let e = io("", &IoColumns::default()).unwrap_err();
    assert!(e.to_string().contains("no data rows"), "{e}");
    let e = io("# only\n\n  \n", &IoColumns::default()).unwrap_err();
    assert!(e.to_string().contains("no data rows"), "{e}");
}

pub fn line_numbers_survive_comments_and_blank_lines() {
    // Line 7 holds the bad cell, after a comment and a blank line mid-file.
    let text = "t,u,y\n0,1,2\n1,1,2\n# note\n\n2,1,2\n3,1,x\n";
    let e = io(text, &IoColumns::default()).unwrap_err();
    assert_eq!(e.line, Some(7), "{e}");
    // A gap after comments: the later sample's own line is named.
    let text = "t,u,y\n0,1,2\n# a\n# b\n1,1,2\n2,1,2\n5,1,2\n6,1,2\n7,1,2\n8,1,2\n9,1,2\n10,1,2\n";
    let e = io(text, &IoColumns::default()).unwrap_err();
    assert_eq!(e.line, Some(7), "{e}");
    assert!(e.to_string().contains("gap"), "{e}");
}

pub fn a_real_gap_is_refused_with_its_line_and_jitter_is_reported() {
    let mut text = String::from("t,u,y\n");
    for k in 0..100 {
        let t = if k < 50 { k as f64 } else { k as f64 + 3.0 };
        text.push_str(&format!("{t},{k},{k}\n"));
    }
    let e = io(&text, &IoColumns::default()).unwrap_err();
    // The first step that is too long, 49 -> 53, is on data row 51 = line 52.
    assert_eq!(e.line, Some(52), "{e}");
    assert_eq!(e.field.as_deref(), Some("t"));

    // Timestamps printed with rounding: steps 1.9998e-4 / 2.0001e-4.
    let mut text = String::from("time,u,y\n");
    let mut t_true = Vec::new();
    for k in 0..1000 {
        let t = k as f64 * 2e-4;
        t_true.push(t);
        text.push_str(&format!(
            "{:.8},{k},{k}\n",
            t + if k % 3 == 1 { 1e-8 } else { 0.0 }
        ));
    }
    let d = io(&text, &IoColumns::default()).unwrap();
    let timing = d.timing.unwrap();
    assert!((timing.ts - 2e-4).abs() < 1e-12, "{timing:?}");
    assert!(
        timing.max_jitter > 0.9e-8 && timing.max_jitter < 2.1e-8,
        "{timing:?}"
    );
    assert!(timing.rms_jitter > 0.5e-8 && timing.rms_jitter < timing.max_jitter);

    // A tight tolerance refuses the same file.
    let strict = IoColumns {
        layout: Layout {
            time_jitter: 1e-6,
            ..Default::default()
        },
        ..Default::default()
    };
    let e = io(&text, &strict).unwrap_err();
    assert!(e.to_string().contains("jitter allowed"), "{e}");
}

pub fn time_units_from_names_units_row_and_option() {
    for (header, want) in [
        ("time_ms", 1e-4),
        ("t [ms]", 1e-4),
        ("Time (ms)", 1e-4),
        ("t_us", 1e-7),
        ("t (µs)", 1e-7),
        ("time_s", 0.1),
        ("Time", 0.1),
        ("t [s]", 0.1),
    ] {
        let text = format!("{header},u,y\n0,1,2\n0.1,3,4\n0.2,5,6\n");
        let d = io(&text, &IoColumns::default()).unwrap();
        let ts = d.ts.unwrap_or_else(|| panic!("{header}: no time found"));
        assert!((ts - want).abs() < 1e-12 * want, "{header}: {ts}");
    }
    // Units row under the header.
    let d = io("t,u,y\nms,V,um\n0,1,2\n0.1,3,4\n", &IoColumns::default()).unwrap();
    let t = d.timing.unwrap();
    assert_eq!(
        (t.unit, t.unit_from),
        (TimeUnit::Milliseconds, UnitSource::UnitsRow)
    );
    assert!((t.ts - 1e-4).abs() < 1e-16);
    // The option wins.
    let cols = with_layout(Layout {
        time_unit: Some(TimeUnit::Microseconds),
        ..Default::default()
    });
    let d = io("time_ms,u,y\n0,1,2\n100,3,4\n", &cols).unwrap();
    assert!((d.ts.unwrap() - 1e-4).abs() < 1e-16);
    // An unknown unit is an error, not seconds.
    let e = io("t [min],u,y\n0,1,2\n1,3,4\n", &IoColumns::default()).unwrap_err();
    assert!(e.to_string().contains("unknown time unit 'min'"), "{e}");
}

pub fn semicolon_decimal_comma_units_row_and_forced_delimiters() {
    let text = "t;u;y\ns;V;um\n0;1,5;2\n0,001;3;-4,25\n";
    let d = io(text, &IoColumns::default()).unwrap();
    assert_eq!(d.input, vec![1.5, 3.0]);
    assert_eq!(d.output, vec![2.0, -4.25]);
    assert!((d.ts.unwrap() - 1e-3).abs() < 1e-18);

    let tab = with_layout(Layout {
        delimiter: Some(Delimiter::Tab),
        ..Default::default()
    });
    let d = io("u\t\ty\n1\t\t2\n3\t\t4\n", &tab).unwrap();
    assert_eq!(d.output, vec![2.0, 4.0]);
    // Sniffed as whitespace, the empty middle field disappears: still u, y by name.
    let d = io("u\t\ty\n1\t\t2\n", &IoColumns::default()).unwrap();
    assert_eq!(d.output, vec![2.0]);

    // --skip-rows skips a description row that is numeric-looking too.
    let skip = with_layout(Layout {
        skip_rows: Some(2),
        ..Default::default()
    });
    let d = io("u,y\nV,um\n99,99\n1,2\n", &skip).unwrap();
    assert_eq!(d.input, vec![1.0]);
}

pub fn quoted_fields_crlf_and_bom() {
    let text = "\u{feff}\"t\",\"u\",\"y\"\r\n0,\"1.5\",2\r\n1,3,4\r\n";
    let d = io(text, &IoColumns::default()).unwrap();
    assert_eq!(d.input, vec![1.5, 3.0]);
    assert_eq!(d.ts, Some(1.0));
}

pub fn write_then_read_is_exact() {
    let t = time_column(4, 1e-4);
    let u = [0.1 + 0.2, 1.0 / 3.0, -1e-300, 5.0];
    let text = write_csv(&["t", "u", "y"], &[&t, &u, &u]);
    let d = read_io(text.as_bytes(), "w.csv", &IoColumns::default(), 1).unwrap();
    assert_eq!(d.input, u);
    assert!((d.ts.unwrap() - 1e-4).abs() < 1e-18);
}

pub fn line_map_counts_runs() {
    let mut m = LineMap::default();
    for line in [2, 3, 4, 7, 8, 20] {
        m.push(line);
    }
    let got: Vec<usize> = (0..6).map(|r| m.line(r)).collect();
    assert_eq!(got, vec![2, 3, 4, 7, 8, 20]);
    assert_eq!(m.runs.len(), 3);
    // A piece numbered from 0, appended 21 lines on: its first run goes on
    // from line 20, its second starts anew; an empty piece changes nothing.
    let mut piece = LineMap::default();
    for line in [0, 1, 5] {
        piece.push(line);
    }
    m.append(LineMap::default(), 100);
    m.append(piece, 21);
    let got: Vec<usize> = (0..9).map(|r| m.line(r)).collect();
    assert_eq!(got, vec![2, 3, 4, 7, 8, 20, 21, 22, 26]);
    assert_eq!(m.runs.len(), 4);
    let mut empty = LineMap::default();
    let mut piece = LineMap::default();
    piece.push(3);
    empty.append(piece, 10);
    assert_eq!((empty.line(0), empty.runs.len()), (13, 1));
}

pub fn time_names() {
    for yes in [
        "t",
        "time",
        "Time",
        "TIME",
        "time_s",
        "time_ms",
        "t [s]",
        "t (us)",
        "Time [ms]",
    ] {
        assert!(is_time_name(yes), "{yes}");
    }
    for no in ["u", "y", "temperature", "tip", "t2", "voltage [V]"] {
        assert!(!is_time_name(no), "{no}");
    }
}

pub fn keep_rows_cuts_both_signals_or_refuses() {
    let mut d = io("u,y\n1,10\n2,20\n3,30\n4,40\n", &IoColumns::default()).unwrap();
    assert_eq!(d.clone().keep_rows(4, None), Err(4));
    assert_eq!(d.clone().keep_rows(1, Some(5)), Err(4));
    assert_eq!(d.clone().keep_rows(2, Some(2)), Err(4));
    d.keep_rows(1, Some(3)).unwrap();
    assert_eq!((d.input, d.output), (vec![2.0, 3.0], vec![20.0, 30.0]));
}

pub fn classic_mac_line_ends_and_quotes_within_a_line() {
    let d = io("t,u,y\r0,1,2\r1,\"3,5\",4\r", &IoColumns::default());
    // A quoted comma is one field (which is then not a number here).
    let e = d.unwrap_err().to_string();
    assert!(e.contains("line 3") && e.contains("'u'"), "{e}");
    let d = io("t,u,y\r0,\"1.5\",2\r1,3,4\r", &IoColumns::default()).unwrap();
    assert_eq!(d.input, vec![1.5, 3.0]);
    let e = io("t,u,y\n0,\"1.5\n\",2\n", &IoColumns::default()).unwrap_err();
    let e = e.to_string();
    assert!(e.contains("line 2") && e.contains("quoted field"), "{e}");
}

/// A record of `rows` rows `t,u,y` = `k/10, k/2, -k`, with a bad cell on
/// row `bad` (1-based data row) if given, and a comment line every 1000.
fn long_record(rows: usize, bad: Option<usize>) -> String {
    let mut text = String::from("t,u,y\n");
    for k in 0..rows {
        if k % 1000 == 999 {
            text.push_str("# a comment line\n");
        }
        if Some(k + 1) == bad {
            text.push_str(&format!("{},oops,{}\n", k as f64 / 10.0, -(k as f64)));
        } else {
            text.push_str(&format!(
                "{},{},{}\n",
                k as f64 / 10.0,
                k as f64 / 2.0,
                -(k as f64)
            ));
        }
    }
    text
}

/// Records longer than a block, cut between threads: every value in
/// order, line numbers counted across blocks and pieces.
pub fn records_read_in_blocks_and_pieces_keep_order_and_lines() {
    let rows = 900_000; // about 19 MB: three blocks, each cut in pieces
    let text = long_record(rows, None);
    assert!(text.len() > 2 * super::BLOCK_BYTES);
    let d = io(&text, &IoColumns::default()).unwrap();
    assert_eq!(d.input.len(), rows);
    for (k, (&u, &y)) in d.input.iter().zip(&d.output).enumerate() {
        assert!(u == k as f64 / 2.0 && y == -(k as f64), "row {k}");
    }
    assert!((d.ts.unwrap() - 0.1).abs() < 1e-12);
    // A bad cell deep in the file: its line is the file's (header, data
    // rows and one comment line per 1000 rows before it).
    // A second bad cell 60,000 rows on, in another piece of the same block
    // (which another thread may parse first), is not the one reported.
    let bad = 800_123;
    let later = "\n86012.2,430061,-860122\n";
    let text = long_record(rows, Some(bad));
    assert!(text.contains(later));
    let text = text.replacen(later, "\n86012.2,oops,-860122\n", 1);
    let e = io(&text, &IoColumns::default()).unwrap_err();
    let line = 1 + bad + (bad - 1) / 1000;
    let text = e.to_string();
    assert!(
        text.contains(&format!("line {line},")) && text.contains("'u'"),
        "{text}"
    );
}

/// Lines longer than a block grow the buffers, and the unfinished line at
/// the end of a grown buffer moves whole into the other one, however much
/// smaller that one is.
pub fn long_lines_grow_the_buffers() {
    const MIB: usize = 1 << 20;
    let mut text = String::from("u,y,z\n");
    // Short rows up to byte `until` of the file, and a long line of `bytes`.
    let mut rows = 0;
    let mut short = |text: &mut String, until: usize| {
        while text.len() < until {
            text.push_str(&format!("{rows},{},0\n", -(rows as f64)));
            rows += 1;
        }
    };
    let long = |text: &mut String, bytes: usize| {
        text.push_str("7,8,");
        text.push_str(&"x".repeat(bytes));
        text.push('\n');
    };
    // The 20 MiB line grows one buffer to 24 MiB; that buffer's next turn
    // ends 22 MiB into the 30 MiB line, more than the other buffer holds.
    short(&mut text, MIB);
    long(&mut text, 20 * MIB);
    short(&mut text, 36 * MIB);
    long(&mut text, 30 * MIB);
    short(&mut text, 68 * MIB);
    let d = io(&text, &IoColumns::default()).unwrap();
    let values: Vec<(f64, f64)> = d
        .input
        .iter()
        .copied()
        .zip(d.output.iter().copied())
        .collect();
    let expected: Vec<(f64, f64)> = text
        .lines()
        .skip(1)
        .map(|line| {
            let mut f = line.split(',');
            let u: f64 = f.next().unwrap().parse().unwrap();
            (u, f.next().unwrap().parse().unwrap())
        })
        .collect();
    assert_eq!(values.len(), expected.len());
    assert!(values == expected);
}

pub fn pieces_are_whole_lines() {
    let text = b"a\nbb\nccc\ndddd\neeeee\n";
    for parts in 1..6 {
        let pieces = super::cut_at_lines(text, parts, 1);
        assert_eq!(pieces.concat(), text.to_vec());
        assert!(pieces.iter().all(|p| p.ends_with(b"\n")));
    }
    assert_eq!(super::cut_at_lines(text, 4, 1 << 10).len(), 1);
    assert_eq!(super::count_lines(b"a\nb"), 2);
    assert_eq!(super::count_lines(b"a\nb\n"), 2);
    assert_eq!(super::count_lines(b""), 0);
}

/// The reader's number parser reads what `str::parse::<f64>` reads, to the
/// same bits, and refuses what it refuses.
pub fn numbers_parse_as_rust_parses_them() {
    let texts = [
        "0",
        "-0",
        "+1.5",
        "1.",
        ".5",
        "1e5",
        "1E-5",
        "-2.5e+300",
        "1e-320",
        "4.9e-324",
        "1e400",
        "-1e400",
        "inf",
        "-inf",
        "Infinity",
        "NaN",
        "nan",
        "0.1",
        "0.30000000000000004",
        "2.2250738585072011e-308",
        "9007199254740993",
        "123456789012345678901234567890",
        "0.0022559138209001794",
        "1e",
        "e5",
        "--1",
        "1.2.3",
        "0x10",
        "1_000",
        "",
        ".",
        "+",
        "1e+",
        "١",
        "1 ",
        " 1",
        "1,5",
    ];
    for text in texts {
        let ours = parse_number(text.as_bytes(), Delimiter::Comma);
        let rust = text.parse::<f64>().ok();
        assert_eq!(ours.map(f64::to_bits), rust.map(f64::to_bits), "{text:?}");
    }
    assert_eq!(parse_number(b"1,5", Delimiter::Semicolon), Some(1.5));
    assert_eq!(parse_number(b"1,5,2", Delimiter::Semicolon), None);
}

/// The fast path takes a line only when the general path reads the same
/// values from it; a line the general path skips, or refuses, or unquotes,
/// it leaves alone.
pub fn plain_lines_read_as_the_general_path_reads_them() {
    let lines = [
        "1,2,3\n",
        "1,2,3",
        "1,2,3\r\n",
        "1,2,3,4\n",
        "1,2,3,\"x\"\n",
        "1,2,3,\"a,b\"\n",
        "1,2\n",
        "1,,3\n",
        ",2,3\n",
        "#1,2,3\n",
        " 1,2,3\n",
        "1 ,2,3\n",
        "1, 2,3\n",
        "\"1\",2,3\n",
        "1,2,3 \n",
        "inf,2,3\n",
        "1,nan,3\n",
        "1e5,2E-3,+4\n",
        "1.,.5,3\n",
        "1,2,3\r",
        "\n",
        ",,\n",
        "1;2;3\n",
        "1,5;2,5;3\n",
        "1\t2\t3\n",
        "1\t 2\t3\n",
        "1e400,2,3\n",
        "0x1,2,3\n",
        "1,2,3#c\n",
        "1,\"2\",3\n",
        "-0,0.30000000000000004,9\n",
        "1,2,3\n4,5,6\n",
    ];
    let layouts: [&[usize]; 4] = [&[0, 1, 2], &[2, 0], &[1], &[2, 1, 0]];
    let delimiters = [Delimiter::Comma, Delimiter::Semicolon, Delimiter::Tab];
    let mut taken = 0;
    for delimiter in delimiters {
        for fields in layouts {
            let plain = plain::PlainLine::new(delimiter, fields).unwrap();
            for line in lines {
                let text = line.as_bytes();
                let mut values = vec![0.0; fields.len()];
                let Some(len) = plain.parse(text, &mut values) else {
                    continue;
                };
                taken += 1;
                let end = memchr::memchr(b'\n', text).map_or(text.len(), |i| i + 1);
                assert_eq!(len, end, "{line:?}");
                let general = general_values(&text[..end], delimiter, fields);
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(
                    general.as_deref().map(bits),
                    Some(bits(&values)),
                    "{line:?} {delimiter:?} {fields:?}"
                );
            }
        }
    }
    assert!(taken >= 20, "{taken}");
    assert!(plain::PlainLine::new(Delimiter::Whitespace, &[0]).is_none());
    assert!(plain::PlainLine::new(Delimiter::Comma, &[1, 1]).is_none());
}

/// What the general path reads from one line: the wanted fields' values,
/// or `None` for a line it skips or refuses.
fn general_values(line: &[u8], delimiter: Delimiter, wanted: &[usize]) -> Option<Vec<f64>> {
    let mut split = rows::Split::new(delimiter);
    let mut fields = rows::Fields::default();
    let row = rows::strip_line_end(line);
    if !split.split(row, &mut fields).ok()? {
        return None;
    }
    wanted
        .iter()
        .map(|&i| {
            let cell = fields.get(row, i).filter(|c| !c.is_empty())?;
            parse_number(cell, delimiter).filter(|v| v.is_finite())
        })
        .collect()
}
