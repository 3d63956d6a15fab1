//! The CSV reader's tests: each finding of a review or a bug hunt, with the input that showed it.

use super::*;

fn parse_text(text: &str) -> Result<Data, DataError> {
    parse(text, Path::new("x.csv"))
}

/// Issue 40, finding 3: a file of 50 rows and 100 000 header columns printed 100 000 "not
/// used" notes (and its header check was quadratic in the columns).
#[test]
fn a_header_of_many_unused_columns_gives_one_note_for_the_rest() {
    let extra: Vec<String> = (0..100_000).map(|i| format!("x{i}")).collect();
    let mut text = format!("t,deflection,torque,{}\n", extra.join(","));
    for r in 0..50 {
        text += &format!("{},{},{}{}\n", f64::from(r) * 0.01, f64::from(r) * 0.001, f64::from(r) * 0.1, ",0".repeat(100_000));
    }
    let d = parse_text(&text).unwrap();
    assert_eq!(d.len(), 50);
    assert_eq!(d.notes.len(), 6, "{:?}", &d.notes[..d.notes.len().min(8)]);
    assert_eq!(d.notes[5], "and 99995 more columns are not used");
    // A duplicate far down the header is still found, with both columns.
    let e = parse_text("t,deflection,torque,a,b,c,a\n0,0,0,0,0,0,0\n").unwrap_err();
    assert!(e.to_string().contains("appears twice in the header (columns 4 and 7)"), "{e}");
}

/// Findings: the reader rejected quoted headers and a UTF-8 BOM (as "missing column `t`"),
/// used a duplicated column silently and said nothing useful for `;`-separated files.
#[test]
fn quoted_headers_and_a_byte_order_mark_are_read() {
    let d = parse_text("\"t\",\"deflection\",\"torque\"\n0,0.001,\"0.1\"\n0.01,0.002,0.2\n").unwrap();
    assert_eq!((d.len(), d.torque[0]), (2, 0.1));
    let d = parse_text("\u{feff}t,deflection,torque\n0,0.001,0.1\n").unwrap();
    assert_eq!(d.len(), 1);
}

/// Found by a hunt for bad input: one deflection of 12 rad in a record within +-0.07 rad
/// (line 1002 of 3000) was fitted as it stood: stiffness 3.40 Nm/rad for about 127, and
/// `check` accepted the characteristic. The row is now an error that says where.
#[test]
fn a_reading_far_outside_the_rest_is_an_error_at_its_line() {
    let row = |i: usize, d: f64| format!("{},{d},{}\n", i as f64 * 0.001, 127.0 * d);
    let mut text = String::from("t,deflection,torque\n");
    for i in 0..3000 {
        text += &row(i, if i == 1000 { 12.0 } else { 0.07 * (i as f64 * 0.01).sin() });
    }
    let e = parse_text(&text).unwrap_err();
    assert!(e.to_string().starts_with("x.csv:1002: column `deflection`: 12 lies far outside the rest"), "{e}");
    // A row of empty fields, which the parser skips, still counts as a line of the file.
    let e = parse_text(&text.replacen("\n", "\n , ,\n", 1)).unwrap_err();
    assert!(e.to_string().starts_with("x.csv:1003: column `deflection`"), "{e}");
    // A lost reading that reads as zero in a column far from zero is a dropout, left to
    // identify (which finds and leaves those out); a motion as far over several samples
    // (5 of 3000, under 0.1 % of them) is data.
    let mut far_from_zero = String::from("t,deflection,torque\n");
    for i in 0..3000 {
        let d = 1.0 + 0.07 * (i as f64 * 0.01).sin();
        far_from_zero += &format!("{},{},{}\n", i as f64 * 0.001, if i == 1000 { 0.0 } else { d }, 20.0 + d);
    }
    assert!(parse_text(&far_from_zero).is_ok());
    let mut excursion = String::from("t,deflection,torque\n");
    for i in 0..3000 {
        let bump = if (1000..1005).contains(&i) { [0.2, 0.5, 0.8, 0.5, 0.2][i - 1000] } else { 0.0 };
        excursion += &row(i, 0.07 * (i as f64 * 0.01).sin() + bump);
    }
    assert!(parse_text(&excursion).is_ok());
    // A departure held over more than 0.1 % of the record (20 of 3000 samples) is part of
    // the data, not one reading.
    let mut smooth = String::from("t,deflection,torque\n");
    for i in 0..3000 {
        smooth += &row(i, 0.07 * (i as f64 * 0.01).sin() + if (990..1010).contains(&i) { 0.5 } else { 0.0 });
    }
    assert!(parse_text(&smooth).is_ok());
}

#[test]
fn a_duplicated_column_is_an_error() {
    let e = parse_text("t,deflection,torque,torque\n0,0,1,2\n").unwrap_err();
    assert_eq!(e.to_string(), "x.csv:1: column `torque`: appears twice in the header (columns 3 and 4): which one is meant?");
}

#[test]
fn another_separator_is_named() {
    let e = parse_text("t;deflection;torque\n0;0;1\n").unwrap_err();
    assert!(e.to_string().ends_with("the file seems separated by `;`: separate columns by commas"), "{e}");
    let e = parse_text("t\tdeflection\ttorque\n0\t0\t1\n").unwrap_err();
    assert!(e.to_string().contains("separated by tabs"), "{e}");
}

/// Finding (issue 36): repetitions logged one file each and concatenated, whose time restarts
/// at zero, were refused as "time does not increase"; Unix-epoch time stamps as "implausible".
#[test]
fn a_restarting_time_is_a_new_repetition_and_epoch_seconds_are_time() {
    // Two repetitions of 50 samples, 0 to 0.98 s each.
    let rows = |n: usize| (0..n).map(|i| format!("{},0,1\n", i as f64 * 0.02)).collect::<String>();
    let d = parse_text(&format!("t,deflection,torque\n{}{}", rows(50), rows(2))).unwrap();
    assert_eq!(d.t[49..], [0.98, 0.98 + RESTART_GAP_S, 1.0 + RESTART_GAP_S]);
    assert!(d.notes[0].starts_with("time restarts at line 52"), "{:?}", d.notes);
    // The repetition is marked where it begins (its time since the last is not known), and
    // a subset keeps the mark at the first sample it takes from it.
    assert_eq!(d.restarts, [50]);
    assert_eq!(d.subset(&[0, 2, 51]).restarts, [2]);
    assert!(d.subset(&[50, 51]).restarts.is_empty());
    // A step back that is not a restart (near the end of a repetition) stays an error, as does a repeat.
    let e = parse_text(&format!("t,deflection,torque\n{}0.9,0,1\n", rows(50))).unwrap_err();
    assert_eq!(e.to_string(), "x.csv:52: column `t`: time 0.9 does not increase (previous 0.98)");
    assert!(parse_text("t,deflection,torque\n0,0,1\n0,0,1\n").is_err());
    let d = parse_text("t,deflection,torque\n1722285643.101,0,1\n1722285643.103,0,1\n").unwrap();
    assert_eq!(d.len(), 2);
}

/// Finding: a log whose time runs backwards at every row was read as 3999 repetitions of one
/// sample each (a note for each) and identified; one whose time steps back and forth, as
/// repetitions of two. A time that goes back before a repetition's worth of samples is an
/// error that says where.
#[test]
fn a_time_that_steps_back_before_a_repetitions_worth_is_an_error() {
    let backwards: String = (0..100).map(|i| format!("{},0,1\n", -(i as f64) * 0.005)).collect();
    let e = parse_text(&format!("t,deflection,torque\n{backwards}")).unwrap_err();
    assert_eq!((e.line, e.column.as_deref()), (3, Some("t")), "{e}");
    assert!(e.to_string().contains("goes back (previous 0) 1 samples after the time began at 0"), "{e}");
    let back_and_forth: String = (0..100).map(|i| format!("{},0,1\n", if i % 2 == 1 { 1.0 } else { -1.0 } * i as f64 * 0.005)).collect();
    let e = parse_text(&format!("t,deflection,torque\n{back_and_forth}")).unwrap_err();
    assert_eq!(e.line, 4, "{e}");
    // Nanoseconds since the epoch are named as such.
    let e = parse_text("t,deflection,torque\n1700000000000000000,0,1\n").unwrap_err();
    assert!(e.to_string().ends_with("(it looks like nanoseconds since the Unix epoch: write seconds)"), "{e}");
}

#[test]
fn errors_name_the_line_of_the_row() {
    let e = parse_text("t,deflection,torque\n0,0,1\n\n0.01,0,x\n").unwrap_err();
    assert_eq!((e.line, e.column.as_deref()), (4, Some("torque")), "{e}");
}

/// A bug hunt's finding: a cell holding a NUL byte (or any control character) was echoed into the
/// error as it stood, and a header of many columns without a required one was echoed whole.
#[test]
fn errors_show_control_characters_escaped_and_long_text_cut() {
    let e = parse_text("t,deflection,torque\n0,0,1\u{0}2\n").unwrap_err().to_string();
    assert_eq!(e, "x.csv:2: column `torque`: `1\\u{0}2` is not a number");
    let e = parse_text("t,de\u{7}flection,torque\n0,0,1\n").unwrap_err().to_string();
    assert!(e.contains("(the header is `t,de\\u{7}flection,torque`)") && !e.contains('\u{7}'), "{e}");
    let names: Vec<String> = (0..100_000).map(|i| format!("x{i}")).collect();
    let e = parse_text(&format!("t,deflection,{}\n0,0,1\n", names.join(","))).unwrap_err().to_string();
    assert!(e.len() < 300 && e.contains("more characters)"), "{} characters: {}", e.len(), &e[..e.len().min(300)]);
    let e = parse_text(&format!("t,deflection,torque\n0,0,{}\n", "9".repeat(10_000))).unwrap_err().to_string();
    assert!(e.len() < 200 && e.contains(" (9960 more characters)"), "{e}");
}

/// A bug hunt's finding: one stray time stamp (a logger's glitch back to the start) was read as a
/// repetition whose time restarted, and the rows after it were laid a second and the whole log
/// later. A restart is told from a stray stamp by the sample after it: a new repetition goes on
/// from its own start, a stray stamp is followed by the old time.
#[test]
fn a_stray_time_stamp_is_an_error_not_a_repetition() {
    let row = |t: f64, i: usize| format!("{t},{},{}\n", 1e-3 * (i as f64 * 0.1).sin(), (i as f64 * 0.1).sin());
    let log = |stray_at: Option<usize>, rows: usize| {
        let mut text = String::from("t,deflection,torque\n");
        for i in 0..rows {
            text += &row(if stray_at == Some(i) { 0.0 } else { 0.01 * (i + 1) as f64 }, i);
        }
        text
    };
    // Row 100 is line 102.
    let e = parse_text(&log(Some(100), 200)).unwrap_err();
    assert_eq!((e.line, e.column.as_deref()), (102, Some("t")), "{e}");
    assert!(e.to_string().contains("line 103's 1.02 resumes after 1: a stray time stamp"), "{e}");
    let e = parse_text(&log(Some(199), 200)).unwrap_err();
    assert_eq!(e.line, 201, "{e}");
    assert!(e.to_string().contains("on the last row: a repetition of one sample is no test"), "{e}");
    // Two true repetitions, each from its own start, still read as two.
    let mut text = log(None, 100);
    for i in 0..100 {
        text += &row(0.01 * (i + 1) as f64, i);
    }
    let d = parse_text(&text).unwrap();
    assert_eq!((d.len(), d.restarts.as_slice()), (200, &[100][..]));
}
