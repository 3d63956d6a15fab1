//! Measured experiments as CSV with a header. Required columns `t` [s], `deflection` [rad],
//! `torque` [Nm]; optional `pivot_mm`, `angle_deg`, `motor_position` [rad], `reference_torque`
//! [Nm] (an empty optional cell is "not given"). Unknown columns are ignored with a note. Every
//! error names the file, line and column.

use std::fmt;
use std::path::{Path, PathBuf};

/// A problem in a data file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DataError {
    /// The file.
    pub file: PathBuf,
    /// 1-based line (0: the whole file).
    pub line: usize,
    /// The column's name, if one.
    pub column: Option<String>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for DataError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: ", self.file.display(), self.line)?;
        if let Some(c) = &self.column {
            write!(f, "column `{c}`: ")?;
        }
        f.write_str(&self.message)
    }
}

impl std::error::Error for DataError {}

/// One experiment, column by column (SI units; pivot in mm, angle in degrees).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Data {
    /// Time [s], strictly increasing (a repetition whose time restarted is laid after the one
    /// before it, see [`RESTART_GAP_S`]).
    pub t: Vec<f64>,
    /// Deflection [rad].
    pub deflection: Vec<f64>,
    /// Torque [Nm].
    pub torque: Vec<f64>,
    /// Pivot setting [mm] per sample: empty when the data has no such column, NaN where a
    /// sample has no value (the optional columns alike; see [`Data::pivot_mm_at`]).
    pub pivot_mm: Vec<f64>,
    /// Deflection direction [deg] per sample (empty or NaN when not given).
    pub angle_deg: Vec<f64>,
    /// Motor position [rad] (empty or NaN when not given).
    pub motor_position: Vec<f64>,
    /// Reference torque [Nm] (empty or NaN when not given).
    pub reference_torque: Vec<f64>,
    /// Notes for the user (ignored columns).
    pub notes: Vec<String>,
    /// Samples where a repetition whose time restarted begins (indices, ascending): its time
    /// since the previous repetition is not known (see [`RESTART_GAP_S`]).
    pub restarts: Vec<usize>,
}

impl Data {
    /// An experiment of the three required columns (time [s], deflection [rad], torque [Nm]);
    /// the optional ones not given (empty: a long record holds no columns of NaN).
    ///
    /// ```
    /// let d = jointctl_ident::csv::Data::from_columns(vec![0.0, 0.01], vec![0.1, 0.2], vec![1.0, 2.0]);
    /// assert_eq!(d.len(), 2);
    /// assert!(d.pivot_mm.is_empty() && d.pivot_mm_at(1).is_nan());
    /// ```
    pub fn from_columns(t: Vec<f64>, deflection: Vec<f64>, torque: Vec<f64>) -> Data {
        Data { t, deflection, torque, ..Data::default() }
    }

    /// Sample `i`'s pivot setting [mm]; NaN when not given.
    ///
    /// ```
    /// let d = jointctl_ident::csv::parse("t,deflection,torque,pivot_mm\n0,0.1,1,40\n0.01,0.1,1,\n", "d.csv".as_ref()).unwrap();
    /// assert_eq!(d.pivot_mm_at(0), 40.0);
    /// assert!(d.pivot_mm_at(1).is_nan());
    /// ```
    pub fn pivot_mm_at(&self, i: usize) -> f64 {
        self.pivot_mm.get(i).copied().unwrap_or(f64::NAN)
    }

    /// Sample `i`'s deflection direction [deg]; NaN when not given.
    ///
    /// ```
    /// let d = jointctl_ident::csv::Data::from_columns(vec![0.0], vec![0.1], vec![1.0]);
    /// assert!(d.angle_deg_at(0).is_nan());
    /// ```
    pub fn angle_deg_at(&self, i: usize) -> f64 {
        self.angle_deg.get(i).copied().unwrap_or(f64::NAN)
    }

    /// The first column whose length is neither the samples' nor zero (a given optional column),
    /// with its length: data built in code can get this wrong; the reader cannot.
    ///
    /// ```
    /// let mut d = jointctl_ident::csv::Data::from_columns(vec![0.0, 0.01], vec![0.1, 0.2], vec![1.0, 2.0]);
    /// assert_eq!(d.uneven_column(), None);
    /// d.pivot_mm = vec![40.0];
    /// assert_eq!(d.uneven_column(), Some(("pivot_mm", 1)));
    /// ```
    pub fn uneven_column(&self) -> Option<(&'static str, usize)> {
        let n = self.len();
        [("deflection", &self.deflection, false), ("torque", &self.torque, false), ("pivot_mm", &self.pivot_mm, true), ("angle_deg", &self.angle_deg, true), ("motor_position", &self.motor_position, true), ("reference_torque", &self.reference_torque, true)]
            .into_iter()
            .find(|(_, c, optional)| c.len() != n && !(*optional && c.is_empty()))
            .map(|(name, c, _)| (name, c.len()))
    }

    /// The pivot settings the samples were taken at, each `(setting [mm], its samples in order)`
    /// in increasing pivot order. A hold is a run of samples in time whose pivot stays within
    /// half of [`SETTING_GAP_MM`] of the run's first reading; a hold of fewer than `min_samples`
    /// samples is the pivot in transit and belongs to no setting; holds whose medians are within
    /// [`SETTING_GAP_MM`] are one setting (a repetition), its value the median of its readings.
    /// Empty without a pivot column; samples without a pivot reading belong to none.
    ///
    /// ```
    /// let mut d = jointctl_ident::csv::Data::from_columns((0..9).map(|i| i as f64 * 0.1).collect(), vec![0.0; 9], vec![0.0; 9]);
    /// // 10 mm held, a move through 15 mm, 20 mm held, then 10 mm again.
    /// d.pivot_mm = vec![10.0, 10.01, 10.02, 15.0, 20.0, 19.99, 20.01, 10.0, 10.01];
    /// let s = d.pivot_settings(2);
    /// assert_eq!(s.len(), 2);
    /// assert_eq!(s[0].1, vec![0, 1, 2, 7, 8]);
    /// assert_eq!(s[1].1, vec![4, 5, 6]);
    /// ```
    pub fn pivot_settings(&self, min_samples: usize) -> Vec<(f64, Vec<usize>)> {
        let p = &self.pivot_mm;
        let mut holds: Vec<Vec<usize>> = Vec::new();
        let mut run: Vec<usize> = Vec::new();
        let mut close = |run: &mut Vec<usize>| {
            if run.len() >= min_samples.max(1) {
                holds.push(std::mem::take(run));
            } else {
                run.clear();
            }
        };
        for i in 0..p.len() {
            if !p[i].is_finite() {
                close(&mut run);
                continue;
            }
            if run.first().is_some_and(|&a| (p[i] - p[a]).abs() > SETTING_GAP_MM / 2.0) {
                close(&mut run);
            }
            run.push(i);
        }
        close(&mut run);
        let median = |idx: &[usize]| {
            let mut v: Vec<f64> = idx.iter().map(|&i| p[i]).collect();
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let mut holds: Vec<(f64, Vec<usize>)> = holds.into_iter().map(|h| (median(&h), h)).collect();
        holds.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut out: Vec<(f64, Vec<usize>)> = Vec::new();
        for (m, h) in holds {
            match out.last_mut() {
                Some((last, samples)) if m - *last <= SETTING_GAP_MM => {
                    samples.extend(h);
                    *last = m;
                }
                _ => out.push((m, h)),
            }
        }
        for (setting, samples) in &mut out {
            samples.sort_unstable();
            *setting = median(samples);
        }
        out
    }

    /// The samples `idx` (in the order given) of every column, the notes kept.
    ///
    /// ```
    /// let d = jointctl_ident::csv::Data::from_columns(vec![0.0, 0.1, 0.2], vec![1.0, 2.0, 3.0], vec![4.0, 5.0, 6.0]);
    /// let s = d.subset(&[0, 2]);
    /// assert_eq!((s.t, s.deflection, s.torque), (vec![0.0, 0.2], vec![1.0, 3.0], vec![4.0, 6.0]));
    /// assert!(s.pivot_mm.is_empty());
    /// ```
    pub fn subset(&self, idx: &[usize]) -> Data {
        let pick = |c: &Vec<f64>| if c.is_empty() { Vec::new() } else { idx.iter().map(|&i| c[i]).collect() };
        Data {
            t: pick(&self.t),
            deflection: pick(&self.deflection),
            torque: pick(&self.torque),
            pivot_mm: pick(&self.pivot_mm),
            angle_deg: pick(&self.angle_deg),
            motor_position: pick(&self.motor_position),
            reference_torque: pick(&self.reference_torque),
            notes: self.notes.clone(),
            // A repetition begins wherever two samples taken one after the other come from
            // different repetitions of this data.
            restarts: (1..idx.len()).filter(|p| self.repetition(idx[*p]) != self.repetition(idx[p - 1])).collect(),
        }
    }

    /// Which repetition sample `i` belongs to, counted from 0: the restarts at or before it.
    ///
    /// ```
    /// // Two repetitions of 50 samples each (see [`MIN_REPETITION_SAMPLES`]), their time from 0.
    /// let rows: String = (0..100).map(|i| format!("{},0,1\n", (i % 50) as f64 * 0.01)).collect();
    /// let d = jointctl_ident::csv::parse(&format!("t,deflection,torque\n{rows}"), "r.csv".as_ref()).unwrap();
    /// assert_eq!((d.repetition(49), d.repetition(50)), (0, 1));
    /// ```
    pub fn repetition(&self, i: usize) -> u32 {
        self.restarts.partition_point(|r| *r <= i) as u32
    }

    /// Samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// No samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
}

/// Pivot readings farther apart than this [mm] are different settings (an assumption: the
/// thesis' settings are 5 mm apart, sections 3.4.2 and 3.5.2, and a held pivot reads within a few
/// hundredths of a millimetre).
pub const SETTING_GAP_MM: f64 = 1.0;

/// The gap [s] a repetition whose time restarts is laid after the previous one with (an
/// assumption: far longer than any logger's step, so identification sees a new segment).
pub const RESTART_GAP_S: f64 = 1.0;

/// The fewest samples a repetition holds before the time may restart for the next (an
/// assumption: a repetition is a test of its own, and fewer samples than identify takes for a
/// whole record, 50, are no test; the last repetition is not held to it, nothing restarts after
/// it). A time that steps back sooner is an error, not a restart: a log whose time runs
/// backwards, or back and forth, was read as thousands of one-sample repetitions and identified.
pub const MIN_REPETITION_SAMPLES: usize = 50;

const KNOWN: [&str; 7] = ["t", "deflection", "torque", "pivot_mm", "angle_deg", "motor_position", "reference_torque"];

/// The largest magnitude each column may hold; beyond it a value is a corrupt cell or a unit
/// mix-up, and it would overflow the fits (a 1e308 torque made the SVD panic). Assumptions,
/// each far beyond any joint of this class: 1e10 s of time (loggers write Unix-epoch seconds,
/// 1.7e9 in 2024; 1e10 is the year 2286); two turns of deflection (the
/// thesis' largest is a few tenths of a radian, figures 3.15-3.26); 1e4 Nm (q2's limit in the
/// reference config is 40 Nm); 1000 mm of pivot travel (the thesis' settings span 0-50 mm,
/// sections 3.4-3.5); +-720 degrees of direction; 1e6 rad of motor position (multi-turn motor counts); 1e4 Nm
/// of reference.
const PLAUSIBLE_ABS: [f64; 7] = [1e10, 4.0 * core::f64::consts::PI, 1e4, 1000.0, 720.0, 1e6, 1e4];

/// Reads a CSV file.
pub fn read(path: &Path) -> Result<Data, DataError> {
    let text = jointctl_files::read_to_string(path, jointctl_files::FileKind::Data).map_err(|e| DataError { file: path.into(), line: 0, column: None, message: e.reason() })?;
    parse(&text, path)
}

/// Parses CSV text; `file` names it in errors. A maintained parser (the `csv` crate) reads it:
/// quoted fields and headers and a UTF-8 byte-order mark are fine; a duplicated column is an
/// error (which one would be meant?), and a file separated by `;` or tabs is told so.
///
/// ```
/// let d = jointctl_ident::csv::parse("t,deflection,torque,extra\n0,0,0,x\n0.01,0.001,0.1,y\n", "a.csv".as_ref()).unwrap();
/// assert_eq!(d.len(), 2);
/// assert_eq!(d.notes, ["column `extra` is not used"]);
/// let e = jointctl_ident::csv::parse("t,deflection,torque\n0,0,zero\n", "a.csv".as_ref()).unwrap_err();
/// assert_eq!(e.to_string(), "a.csv:2: column `torque`: `zero` is not a number");
/// let e = jointctl_ident::csv::parse("t,deflection,torque\n0,0,1\n0.01,0.15,0.001,0.2\n", "a.csv".as_ref()).unwrap_err();
/// assert_eq!(e.to_string(), "a.csv:3: 4 fields where the header names 3 columns (the first value beyond them, `0.2`, in column 4): a row shifted or run together");
/// let e = jointctl_ident::csv::parse("t,deflection,torque\n0,0,1e308\n", "a.csv".as_ref()).unwrap_err();
/// assert_eq!(e.to_string(), "a.csv:2: column `torque`: 1e308 is implausible: this column holds values within +-10000");
/// ```
pub fn parse(text: &str, file: &Path) -> Result<Data, DataError> {
    let err = |line: usize, column: Option<&str>, message: String| DataError { file: file.into(), line, column: column.map(shown), message };
    // The parser strips a UTF-8 byte-order mark itself; `trim` takes blanks around fields.
    let mut reader = ::csv::ReaderBuilder::new().flexible(true).trim(::csv::Trim::All).from_reader(text.as_bytes());
    let header = match reader.headers() {
        Ok(h) => h.clone(),
        Err(e) => return Err(err(e.position().map_or(1, |p| p.line() as usize), None, format!("unreadable header: {e}"))),
    };
    let h = 1 + text.lines().take_while(|l| l.trim().is_empty()).count();
    if header.iter().all(str::is_empty) {
        return Err(err(0, None, "the file is empty; expected a header `t,deflection,torque,...` and samples".into()));
    }
    let names: Vec<&str> = header.iter().collect();
    // Each name's first column, in one pass (a search back from every column was quadratic: a
    // header of 100 000 columns took 20 s).
    let mut first_of: std::collections::HashMap<&str, usize> = std::collections::HashMap::with_capacity(names.len());
    for (i, n) in names.iter().enumerate() {
        if let Some(first) = first_of.insert(n, i) {
            return Err(err(h, Some(n), format!("appears twice in the header (columns {} and {}): which one is meant?", first + 1, i + 1)));
        }
    }
    let col = |name: &str| names.iter().position(|n| *n == name);
    for required in ["t", "deflection", "torque"] {
        if col(required).is_none() {
            let header_text: String = names.join(",");
            let hint = [(';', "`;`"), ('\t', "tabs")]
                .iter()
                .find(|(c, _)| names.len() == 1 && header_text.contains(*c))
                .map(|(_, what)| format!("; the file seems separated by {what}: separate columns by commas"))
                .unwrap_or_default();
            return Err(err(h, Some(required), format!("missing required column (the header is `{}`){hint}", shown(&header_text))));
        }
    }
    let mut data = Data::default();
    // The columns not used, in one note from the sixth on (a file of 100 000 columns printed
    // 100 000 notes).
    let unused: Vec<&&str> = names.iter().filter(|n| !KNOWN.contains(n)).collect();
    for n in unused.iter().take(5) {
        data.notes.push(format!("column `{}` is not used", shown(n)));
    }
    if unused.len() > 5 {
        data.notes.push(format!("and {} more columns are not used", unused.len() - 5));
    }
    let idx: Vec<Option<usize>> = KNOWN.iter().map(|k| col(k)).collect();
    // Time added to the file's own since the last restart, and where that repetition began.
    let (mut shift, mut segment_start) = (0.0, 0usize);
    // After a restart, until the next sample: the restart's line, its time and the previous
    // repetition's last time (a stray stamp is told from a restart by the sample after it).
    let mut just_restarted: Option<(usize, f64, f64)> = None;
    // The file's line of a parser position: the parser's own line count skips blank lines, and
    // a record's byte position can point at the blank lines before it. Positions only grow:
    // newlines are counted from the previous one (counting from the start made a long file
    // quadratic: hours for 2 million rows).
    let counted = std::cell::Cell::new((0usize, 0usize));
    let line_of = |p: Option<&::csv::Position>| {
        p.map_or(0, |p| {
            let start = (p.byte() as usize).min(text.len());
            let blank = text[start..].bytes().take_while(|b| *b == b'\n' || *b == b'\r').count();
            let end = start + blank;
            let (mut at, mut lines) = counted.get();
            if end < at {
                (at, lines) = (0, 0);
            }
            lines += text.as_bytes()[at..end].iter().filter(|b| **b == b'\n').count();
            counted.set((end, lines));
            lines + 1
        })
    };
    for record in reader.records() {
        let record = record.map_err(|e| err(line_of(e.position()), None, format!("unreadable row: {e}")))?;
        if record.iter().all(str::is_empty) {
            continue;
        }
        let line = line_of(record.position());
        // A value beyond the header's columns (a row shifted by an inserted value, two rows run
        // together) leaves every named column's cell in doubt: read as it stood, one shifted row
        // moved identify's held-out error by a fifth and the fit's largest error six times.
        if let Some(extra) = record.iter().skip(names.len()).position(|f| !f.is_empty()) {
            return Err(err(line, None, format!("{} fields where the header names {} columns (the first value beyond them, `{}`, in column {}): a row shifted or run together", record.len(), names.len(), shown(&record[names.len() + extra]), names.len() + extra + 1)));
        }
        let mut values = [f64::NAN; 7];
        for (k, c) in idx.iter().enumerate() {
            let Some(c) = c else { continue };
            let cell = record.get(*c).unwrap_or("");
            if cell.is_empty() {
                if k < 3 {
                    return Err(err(line, Some(KNOWN[k]), "empty cell in a required column".into()));
                }
                continue;
            }
            let v: f64 = cell.parse().map_err(|_| err(line, Some(KNOWN[k]), format!("`{}` is not a number", shown(cell))))?;
            if !v.is_finite() {
                return Err(err(line, Some(KNOWN[k]), format!("`{}` is not a finite number", shown(cell))));
            }
            if v.abs() > PLAUSIBLE_ABS[k] {
                // Loggers that stamp nanoseconds (ROS, many DAQs) write 1.7e18 in 2024.
                let hint = if k == 0 && (1e17..1e20).contains(&v.abs()) { " (it looks like nanoseconds since the Unix epoch: write seconds)" } else { "" };
                return Err(err(line, Some(KNOWN[k]), format!("{} is implausible: this column holds values within +-{}{hint}", shown(cell), PLAUSIBLE_ABS[k])));
            }
            values[k] = v;
        }
        // Repetitions logged one file each and concatenated: the time restarts near where the
        // repetition began. The new repetition is laid after the previous one with a gap of
        // RESTART_GAP_S (so time increases and identification sees a new segment); any other
        // step back, or a time that repeats, is an error.
        let (raw, mut at) = (values[0], values[0] + shift);
        if let Some((restart_line, restart_raw, before)) = just_restarted.take()
            && raw > before
        {
            return Err(err(restart_line, Some("t"), stray_stamp(restart_raw, before, line, raw)));
        }
        if let Some(&prev) = data.t.last() {
            let (start, prev_raw) = (data.t[segment_start] - shift, prev - shift);
            let restarts = raw < prev_raw && raw <= start + 0.1 * (prev_raw - start);
            let held = data.t.len() - segment_start;
            if restarts && held < MIN_REPETITION_SAMPLES {
                return Err(err(
                    line,
                    Some("t"),
                    format!("time {raw} goes back (previous {prev_raw}) {held} samples after the time began at {start}: a repetition whose time restarts holds at least {MIN_REPETITION_SAMPLES} samples; within one, time must increase"),
                ));
            }
            if restarts {
                shift = prev + RESTART_GAP_S - raw;
                at = raw + shift;
                segment_start = data.t.len();
                data.restarts.push(data.t.len());
                just_restarted = Some((line, raw, prev_raw));
                data.notes.push(format!("time restarts at line {line} ({raw} after {prev_raw}): a new repetition, laid {RESTART_GAP_S} s after the previous one"));
            } else if at <= prev {
                return Err(err(line, Some("t"), format!("time {raw} does not increase (previous {prev_raw})")));
            }
        }
        data.t.push(at);
        data.deflection.push(values[1]);
        data.torque.push(values[2]);
        // An optional column the file does not have stays empty.
        for (k, column) in [&mut data.pivot_mm, &mut data.angle_deg, &mut data.motor_position, &mut data.reference_torque].into_iter().enumerate() {
            if idx[k + 3].is_some() {
                column.push(values[k + 3]);
            }
        }
    }
    if data.is_empty() {
        return Err(err(h + 1, None, "the file has a header but no samples".into()));
    }
    if let Some((line, raw, before)) = just_restarted {
        return Err(err(line, Some("t"), format!("time {raw} steps back from {before} on the last row: a repetition of one sample is no test (a stray time stamp?); remove the row")));
    }
    for (name, column) in [("deflection", &data.deflection), ("torque", &data.torque)] {
        if let Some((row, low, high)) = far_outlier(column) {
            // The parser skips a row whose every field is empty (quotes and blanks aside): so
            // does this count.
            let empty_row = |l: &str| l.split(',').all(|f| f.trim().trim_matches('"').trim().is_empty());
            let line = text.lines().enumerate().skip(h).filter(|(_, l)| !empty_row(l)).nth(row).map_or(0, |(i, _)| i + 1);
            return Err(err(
                line,
                Some(name),
                format!("{} lies far outside the rest of the column (0.1-99.9 % of it within {low:.4e} to {high:.4e}): a corrupt reading? Fix or remove the row", column[row]),
            ));
        }
    }
    Ok(data)
}

/// Why a time that stepped back at `line` and resumed after it is not a restart.
fn stray_stamp(raw: f64, before: f64, next_line: usize, next: f64) -> String {
    format!("time {raw} steps back from {before}, and line {next_line}'s {next} resumes after {before}: a stray time stamp, not a repetition whose time restarts; fix or remove the row")
}

/// The first value of `x` that jumps out from both its neighbours and lies beyond the column's
/// 0.1 % and 99.9 % quantiles, each by more than [`FAR_SPANS`] times their span, with the two
/// quantiles: a reading no continuous signal makes (a corrupt cell, a unit mixed up in one row).
/// A motion that goes as far over several samples is data, and so is a value of exactly zero: a
/// lost reading that reads as zero is a dropout, which identify finds and leaves out itself.
/// The quantiles come from at most 100 000 evenly spaced values, so that a 2-million-row file
/// is not copied again; a record of fewer than 2000 values, or whose bulk is one value, is not
/// judged (there is no spread to judge by).
fn far_outlier(x: &[f64]) -> Option<(usize, f64, f64)> {
    if x.len() < 2000 {
        return None;
    }
    let stride = x.len().div_ceil(100_000);
    let mut some: Vec<f64> = x.iter().step_by(stride).copied().collect();
    let n = some.len();
    let low = *some.select_nth_unstable_by(n / 1000, f64::total_cmp).1;
    let high = *some.select_nth_unstable_by(n - 1 - n / 1000, f64::total_cmp).1;
    let far = FAR_SPANS * (high - low);
    if far <= 0.0 {
        return None;
    }
    let row = (1..x.len() - 1).find(|&i| {
        let v = x[i];
        v != 0.0 && (v < low - far || v > high + far) && (v - x[i - 1]).abs() > far && (v - x[i + 1]).abs() > far
    })?;
    Some((row, low, high))
}

/// How many spans of the bulk (0.1-99.9 %) a value must lie beyond it, and jump from each
/// neighbour, to be far out (an assumption: a jump of three such spans between two samples and
/// back is one no joint's deflection or torque makes).
const FAR_SPANS: f64 = 3.0;

/// The most characters of a cell or a name an error or a note shows (an assumption: a number
/// or a column name fits; a longer cell is garbage whose start says enough).
const SHOWN_CHARS: usize = 40;

/// A cell or a column name as an error or a note shows it: control characters escaped (a NUL
/// byte in a cell went to the terminal as it stood) and at most [`SHOWN_CHARS`] characters, with
/// how many more there are (a 100 000-column header was echoed whole).
fn shown(text: &str) -> String {
    let mut out = String::new();
    for c in text.chars().take(SHOWN_CHARS) {
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    let more = text.chars().count().saturating_sub(SHOWN_CHARS);
    if more > 0 {
        out.push_str(&format!("... ({more} more characters)"));
    }
    out
}

#[cfg(test)]
mod tests;
