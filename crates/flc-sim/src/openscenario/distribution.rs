//! `ParameterValueDistribution` files (OpenSCENARIO 1.x): a `ScenarioFile` and a `Deterministic`
//! set of parameter distributions, expanded into one parameter assignment per run.
//!
//! Supported: `DeterministicSingleParameterDistribution` with a `DistributionSet` or a
//! `DistributionRange`, and `DeterministicMultiParameterDistribution` with a
//! `ValueSetDistribution`. `Stochastic` and `UserDefinedDistribution` are errors (unsupported).
//!
//! The number of runs is computed before anything is expanded; more than [`MAX_RUNS`] is an
//! error naming the count, so a hostile file asking for millions of combinations costs nothing.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::error::ImportError;
use super::params::Params;
use super::xml;

/// Most runs one distribution file may ask for.
pub const MAX_RUNS: u64 = 100_000;

/// Largest total size of the expanded runs (the sum over all runs of each parameter's name and
/// value lengths plus 64 bytes per pair), bytes: a few runs repeating huge value sets must not
/// grow memory without bound either.
pub const MAX_EXPANDED_BYTES: u128 = 128 * 1024 * 1024;

/// Slack of a `DistributionRange`, as a fraction of `stepWidth`: a value counts as inside the
/// range when it exceeds `upperLimit` by at most this much of a step (so `0..0.3` by `0.1`
/// gives 4 values despite rounding).
pub const RANGE_SLACK: f64 = 1e-9;

/// A distribution file read: the scenario it varies and its runs, each a parameter assignment
/// computed on demand ([`Distribution::run`]): nothing is expanded, so a file of 100,000 runs
/// costs the size of its value lists.
#[derive(Debug, Clone, PartialEq)]
pub struct Distribution {
    /// `ScenarioFile@filepath`, resolved relative to the distribution file's folder.
    pub scenario_file: PathBuf,
    /// Each distribution's choices, in file order.
    choices: Vec<Choices>,
    /// The number of runs ([`MAX_RUNS`] at most).
    len: usize,
}

impl Distribution {
    /// The number of runs (the product of the distributions' value counts).
    pub fn len(&self) -> usize {
        self.len
    }

    /// `true` for no run (never: every distribution has at least one value).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Run `i` (0-based): parameter name -> value text, in the order the distributions (and,
    /// within a `ParameterValueSet`, the assignments) appear in the file; `None` for `i >=
    /// len()`. Computed from `i` alone (no other run is built).
    ///
    /// Runs are in the order of esmini 3.6.0's `--param_permutation i` (run `i` here is
    /// esmini's permutation `i`): the combinations are counted like the digits of a number
    /// whose most significant digit is the FIRST distribution in the file and whose least
    /// significant digit is the LAST, i.e. the last distribution varies fastest and the first
    /// slowest (esmini's `OSCParameterDistribution`, which decomposes the permutation index
    /// from the last distribution backwards). Single- and multi-parameter distributions count
    /// alike, in file order.
    pub fn run(&self, i: usize) -> Option<Vec<(String, String)>> {
        if i >= self.len {
            return None;
        }
        let mut picks = vec![0usize; self.choices.len()];
        let mut rest = i;
        for (pick, c) in picks.iter_mut().zip(&self.choices).rev() {
            let n = c.len().max(1);
            *pick = rest % n;
            rest /= n;
        }
        Some(self.choices.iter().zip(&picks).filter_map(|(c, &k)| c.get(k)).flatten().cloned().collect())
    }

    /// Every run in order ([`Distribution::run`]), built one at a time.
    pub fn runs(&self) -> impl Iterator<Item = Vec<(String, String)>> + '_ {
        (0..self.len).filter_map(|i| self.run(i))
    }
}

/// Whether `doc` is a distribution file: an `OpenSCENARIO` root holding a
/// `ParameterValueDistribution`.
pub fn is_distribution(doc: &roxmltree::Document<'_>) -> bool {
    let root = doc.root_element();
    root.tag_name().name() == "OpenSCENARIO" && xml::child(root, "ParameterValueDistribution").is_some()
}

/// One distribution's values, each a list of (parameter, value text).
type Choices = Vec<Vec<(String, String)>>;

/// Reads the distribution file `doc` (read from `file`): the scenario file and every run's
/// parameter values (order: see [`Distribution::runs`]). `DistributionRange` gives
/// `lowerLimit + k * stepWidth` for `k = 0, 1, ...` while within `upperLimit` (with
/// [`RANGE_SLACK`]), written with at most 12 significant digits (so `0.1 * 3` is `0.3`; esmini
/// writes six decimals, `0.300000`, the same number to that precision).
pub fn read(doc: &roxmltree::Document<'_>, file: &Path) -> Result<Distribution, ImportError> {
    let f = file.display().to_string();
    let f = f.as_str();
    let root = doc.root_element();
    if root.tag_name().name() != "OpenSCENARIO" {
        return Err(ImportError::at(f, root, "the root element of a distribution file must be <OpenSCENARIO>"));
    }
    let pvd = xml::child(root, "ParameterValueDistribution")
        .ok_or_else(|| ImportError::at(f, root, "no <ParameterValueDistribution>: not a distribution file"))?;
    // Attribute values are literal (a distribution file declares no parameters): `${expr}` of
    // constants works, `$name` is an error.
    let p = Params::new();
    let sf = xml::child(pvd, "ScenarioFile").ok_or_else(|| ImportError::at(f, pvd, "<ScenarioFile> is missing"))?;
    let path = p.req_str(sf, "filepath", f)?;
    if path.trim().is_empty() {
        return Err(ImportError::at(f, sf, "empty filepath"));
    }
    let scenario_file = file.parent().unwrap_or_else(|| Path::new("")).join(path.trim());

    if let Some(st) = xml::child(pvd, "Stochastic") {
        return Err(ImportError::at(f, st, "unsupported element: Stochastic distributions are not supported (only Deterministic)"));
    }
    let det = xml::child(pvd, "Deterministic").ok_or_else(|| ImportError::at(f, pvd, "<Deterministic> is missing"))?;
    for c in xml::elements(pvd) {
        if !matches!(c.tag_name().name(), "ScenarioFile" | "Deterministic") {
            return Err(ImportError::at(f, c, "unexpected element in <ParameterValueDistribution>"));
        }
    }

    // Pass 1: structure and counts, nothing expanded.
    let dists: Vec<roxmltree::Node<'_, '_>> = xml::elements(det).collect();
    if dists.is_empty() {
        return Err(ImportError::at(f, det, "no distribution in <Deterministic>"));
    }
    let mut counts = Vec::with_capacity(dists.len());
    let mut total: Option<u128> = Some(1);
    for &d in &dists {
        let n = count(&p, d, f)?;
        total = total.and_then(|t| t.checked_mul(u128::from(n)));
        counts.push(n);
    }
    match total {
        Some(t) if t <= u128::from(MAX_RUNS) => {}
        Some(t) => {
            let each: Vec<String> = counts.iter().map(u64::to_string).collect();
            return Err(ImportError::at(f, det, format!("{} = {t} combinations, more than the limit of {MAX_RUNS}", each.join(" x "))));
        }
        None => return Err(ImportError::at(f, det, format!("more than {} combinations (limit {MAX_RUNS})", u128::MAX))),
    }

    // Pass 2: the values of each distribution (each at most MAX_RUNS of them).
    let mut owner: BTreeMap<String, u32> = BTreeMap::new();
    let mut all: Vec<Choices> = Vec::with_capacity(dists.len());
    for &d in &dists {
        let choices = values(&p, d, f)?;
        let line = xml::line(d);
        let mut names: Vec<&String> = choices.iter().flatten().map(|(n, _)| n).collect();
        names.sort();
        names.dedup();
        for n in names {
            if let Some(first) = owner.insert(n.clone(), line) {
                return Err(ImportError::at(f, d, format!("parameter `{n}` is already varied by the distribution at line {first}")));
            }
        }
        all.push(choices);
    }

    // The size of the expansion: each choice of distribution k appears total / count_k times.
    let total = counts.iter().product::<u64>();
    let mut bytes: u128 = 0;
    for (choices, &n) in all.iter().zip(&counts) {
        let size: u128 = choices.iter().flatten().map(|(a, b)| (a.len() + b.len() + 64) as u128).sum();
        bytes = bytes.saturating_add(size.saturating_mul(u128::from(total / n.max(1))));
    }
    if bytes > MAX_EXPANDED_BYTES {
        return Err(ImportError::at(
            f,
            det,
            format!("the {total} runs would hold {bytes} bytes of parameter values, more than the limit of {MAX_EXPANDED_BYTES}"),
        ));
    }

    // The runs are computed on demand (`Distribution::run`), the last distribution varying
    // fastest.
    Ok(Distribution { scenario_file, choices: all, len: usize::try_from(total).unwrap_or(usize::MAX) })
}

/// Name of the parameter a single distribution varies (written without `$`).
fn parameter_name(d: roxmltree::Node<'_, '_>, attr: &str, f: &str) -> Result<String, ImportError> {
    let name = d.attribute(attr).unwrap_or_default().trim();
    if name.is_empty() || name.starts_with('$') {
        return Err(ImportError {
            file: f.to_string(),
            line: xml::line(d),
            element: format!("{}@{attr}", d.tag_name().name()),
            message: format!("`{name}`: a parameter name, non-empty and written without `$`, is required"),
        });
    }
    Ok(name.to_string())
}

/// The one distribution element of a `DeterministicSingleParameterDistribution`.
fn single_kind<'a, 'i>(d: roxmltree::Node<'a, 'i>, f: &str) -> Result<roxmltree::Node<'a, 'i>, ImportError> {
    let mut kids = xml::elements(d);
    let k = kids.next().ok_or_else(|| ImportError::at(f, d, "no DistributionSet or DistributionRange"))?;
    if let Some(extra) = kids.next() {
        return Err(ImportError::at(f, extra, "a single-parameter distribution holds exactly one distribution"));
    }
    match k.tag_name().name() {
        "DistributionSet" | "DistributionRange" => Ok(k),
        "UserDefinedDistribution" => Err(ImportError::at(f, k, "unsupported element: UserDefinedDistribution is not supported")),
        _ => Err(ImportError::at(f, k, "unexpected element (DistributionSet or DistributionRange expected)")),
    }
}

/// `lowerLimit`, `stepWidth` and the number of values of a `DistributionRange`.
fn range(p: &Params, r: roxmltree::Node<'_, '_>, f: &str) -> Result<(f64, f64, u64), ImportError> {
    let step = p.req_num(r, "stepWidth", f)?;
    if step <= 0.0 {
        return Err(ImportError::at(f, r, format!("stepWidth {step} must be positive")));
    }
    let lim = xml::child(r, "Range").ok_or_else(|| ImportError::at(f, r, "<Range> is missing"))?;
    let lo = p.req_num(lim, "lowerLimit", f)?;
    let hi = p.req_num(lim, "upperLimit", f)?;
    if hi < lo {
        return Err(ImportError::at(f, lim, format!("upperLimit {hi} is below lowerLimit {lo}")));
    }
    let steps = ((hi - lo) / step + RANGE_SLACK).floor();
    if !steps.is_finite() || steps >= MAX_RUNS as f64 {
        return Err(ImportError::at(
            f,
            r,
            format!("{lo}..{hi} by {step} gives {:e} values, more than the limit of {MAX_RUNS}", steps + 1.0),
        ));
    }
    Ok((lo, step, steps as u64 + 1))
}

/// Number of choices of distribution `d` (validating its structure, expanding nothing).
fn count(p: &Params, d: roxmltree::Node<'_, '_>, f: &str) -> Result<u64, ImportError> {
    let n = match d.tag_name().name() {
        "DeterministicSingleParameterDistribution" => {
            parameter_name(d, "parameterName", f)?;
            let k = single_kind(d, f)?;
            if k.tag_name().name() == "DistributionSet" {
                let n = xml::children(k, "Element").count();
                if n == 0 {
                    return Err(ImportError::at(f, k, "no <Element> in the DistributionSet"));
                }
                n as u64
            } else {
                range(p, k, f)?.2
            }
        }
        "DeterministicMultiParameterDistribution" => {
            let vs = xml::child(d, "ValueSetDistribution").ok_or_else(|| ImportError::at(f, d, "<ValueSetDistribution> is missing"))?;
            let n = xml::children(vs, "ParameterValueSet").count();
            if n == 0 {
                return Err(ImportError::at(f, vs, "no <ParameterValueSet> in the ValueSetDistribution"));
            }
            n as u64
        }
        _ => return Err(ImportError::at(f, d, "unexpected element in <Deterministic>")),
    };
    if n > MAX_RUNS {
        return Err(ImportError::at(f, d, format!("{n} values, more than the limit of {MAX_RUNS} combinations")));
    }
    Ok(n)
}

/// `x` with at most 12 significant digits, in the shortest form that reads back as that number.
fn range_text(x: f64) -> String {
    let rounded: f64 = format!("{x:.11e}").parse().unwrap_or(x);
    let v = if rounded == 0.0 { 0.0 } else { rounded };
    format!("{v}")
}

/// The choices of distribution `d` (already counted and checked by [`count`]).
fn values(p: &Params, d: roxmltree::Node<'_, '_>, f: &str) -> Result<Choices, ImportError> {
    if d.tag_name().name() == "DeterministicSingleParameterDistribution" {
        let name = parameter_name(d, "parameterName", f)?;
        let k = single_kind(d, f)?;
        if k.tag_name().name() == "DistributionSet" {
            for c in xml::elements(k) {
                if c.tag_name().name() != "Element" {
                    return Err(ImportError::at(f, c, "unexpected element in <DistributionSet>"));
                }
            }
            return xml::children(k, "Element").map(|e| Ok(vec![(name.clone(), p.req_str(e, "value", f)?)])).collect();
        }
        let (lo, step, n) = range(p, k, f)?;
        return Ok((0..n).map(|i| vec![(name.clone(), range_text(lo + i as f64 * step))]).collect());
    }
    let vs = xml::child(d, "ValueSetDistribution").ok_or_else(|| ImportError::at(f, d, "<ValueSetDistribution> is missing"))?;
    let mut out = Vec::new();
    for set in xml::elements(vs) {
        if set.tag_name().name() != "ParameterValueSet" {
            return Err(ImportError::at(f, set, "unexpected element in <ValueSetDistribution>"));
        }
        let mut one: Vec<(String, String)> = Vec::new();
        for a in xml::elements(set) {
            if a.tag_name().name() != "ParameterAssignment" {
                return Err(ImportError::at(f, a, "unexpected element in <ParameterValueSet>"));
            }
            let name = parameter_name(a, "parameterRef", f)?;
            if one.iter().any(|(n, _)| *n == name) {
                return Err(ImportError::at(f, a, format!("parameter `{name}` is assigned twice in this ParameterValueSet")));
            }
            one.push((name, p.req_str(a, "value", f)?));
        }
        if one.is_empty() {
            return Err(ImportError::at(f, set, "no <ParameterAssignment> in the ParameterValueSet"));
        }
        out.push(one);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(det: &str) -> String {
        format!(
            r#"<?xml version="1.0"?>
<OpenSCENARIO>
  <FileHeader revMajor="1" revMinor="2" date="2024-01-01T00:00:00" description="d" author="a"/>
  <ParameterValueDistribution>
    <ScenarioFile filepath="cut_in.xosc"/>
    <Deterministic>
{det}
    </Deterministic>
  </ParameterValueDistribution>
</OpenSCENARIO>"#
        )
    }

    /// A distribution with its runs expanded (the tests compare them whole).
    #[derive(Debug)]
    struct Expanded {
        scenario_file: PathBuf,
        runs: Vec<Vec<(String, String)>>,
    }

    fn read_str(text: &str) -> Result<Expanded, ImportError> {
        let doc = xml::parse(text, "dist/d.xosc")?;
        let d = read(&doc, Path::new("dist/d.xosc"))?;
        assert_eq!(d.run(d.len()), None);
        Ok(Expanded { runs: d.runs().collect(), scenario_file: d.scenario_file })
    }

    /// Run `i` is computed alone: the last run of a 100,000-run file, at once.
    #[test]
    fn one_run_without_the_others() {
        let r = range_xml("a", "1", "1000", "1") + &range_xml("b", "1", "100", "1");
        let text = file(&r);
        let doc = xml::parse(&text, "d").expect("xml");
        let t = std::time::Instant::now();
        let d = read(&doc, Path::new("d.xosc")).expect("read");
        let last = d.run(99_999).expect("last");
        assert!(t.elapsed().as_secs_f64() < 0.5);
        assert_eq!(d.len(), 100_000);
        assert_eq!(pairs(&last), vec![("a", "1000"), ("b", "100")]);
        assert_eq!(pairs(&d.run(101).expect("101")), vec![("a", "2"), ("b", "2")]);
        assert_eq!(d.run(100_000), None);
    }

    fn pairs(run: &[(String, String)]) -> Vec<(&str, &str)> {
        run.iter().map(|(a, b)| (a.as_str(), b.as_str())).collect()
    }

    fn set(name: &str, values: &[&str]) -> String {
        let els: String = values.iter().map(|v| format!(r#"<Element value="{v}"/>"#)).collect();
        format!(
            r#"<DeterministicSingleParameterDistribution parameterName="{name}"><DistributionSet>{els}</DistributionSet></DeterministicSingleParameterDistribution>"#
        )
    }

    fn range_xml(name: &str, lo: &str, hi: &str, step: &str) -> String {
        format!(
            r#"<DeterministicSingleParameterDistribution parameterName="{name}"><DistributionRange stepWidth="{step}"><Range lowerLimit="{lo}" upperLimit="{hi}"/></DistributionRange></DeterministicSingleParameterDistribution>"#
        )
    }

    #[test]
    fn two_by_two_in_esmini_order() {
        let text = file(&(set("speed", &["10", "20"]) + &set("gap", &["5", "${2 * 4}"])));
        let doc = xml::parse(&text, "d").expect("xml");
        assert!(is_distribution(&doc));
        let d = read_str(&text).expect("read");
        assert_eq!(d.scenario_file, Path::new("dist/cut_in.xosc"));
        let runs: Vec<_> = d.runs.iter().map(|r| pairs(r)).collect();
        assert_eq!(
            runs,
            vec![
                vec![("speed", "10"), ("gap", "5")],
                vec![("speed", "10"), ("gap", "8")],
                vec![("speed", "20"), ("gap", "5")],
                vec![("speed", "20"), ("gap", "8")],
            ]
        );
    }

    #[test]
    fn ranges() {
        let d = read_str(&file(&range_xml("v", "10", "20", "10"))).expect("read");
        assert_eq!(d.runs.iter().map(|r| pairs(r)).collect::<Vec<_>>(), vec![vec![("v", "10")], vec![("v", "20")]]);
        let d = read_str(&file(&range_xml("v", "0", "0.3", "0.1"))).expect("read");
        let vals: Vec<&str> = d.runs.iter().flat_map(|r| r.iter().map(|(_, v)| v.as_str())).collect();
        assert_eq!(vals, ["0", "0.1", "0.2", "0.3"]);
        let d = read_str(&file(&range_xml("v", "-1", "1.5", "1"))).expect("read");
        let vals: Vec<&str> = d.runs.iter().flat_map(|r| r.iter().map(|(_, v)| v.as_str())).collect();
        assert_eq!(vals, ["-1", "0", "1"]);
        let d = read_str(&file(&range_xml("v", "3", "3", "1"))).expect("read");
        assert_eq!(d.runs.len(), 1);
        for (lo, hi, step, msg) in [
            ("0", "1", "0", "must be positive"),
            ("0", "1", "-1", "must be positive"),
            ("0", "1", "NaN", "not a finite number"),
            ("0", "1", "inf", "not a finite number"),
            ("2", "1", "1", "below lowerLimit"),
            ("0", "1e300", "1e-300", "more than the limit"),
            ("-1e308", "1e308", "1", "more than the limit"),
        ] {
            let e = read_str(&file(&range_xml("v", lo, hi, step))).expect_err(msg).to_string();
            assert!(e.contains(msg), "{lo} {hi} {step}: {e}");
        }
    }

    #[test]
    fn multi_parameter_sets() {
        let multi = r#"<DeterministicMultiParameterDistribution><ValueSetDistribution>
  <ParameterValueSet><ParameterAssignment parameterRef="a" value="1"/><ParameterAssignment parameterRef="b" value="x"/></ParameterValueSet>
  <ParameterValueSet><ParameterAssignment parameterRef="a" value="2"/><ParameterAssignment parameterRef="b" value="y"/></ParameterValueSet>
  <ParameterValueSet><ParameterAssignment parameterRef="a" value="3"/></ParameterValueSet>
</ValueSetDistribution></DeterministicMultiParameterDistribution>"#;
        let d = read_str(&file(multi)).expect("read");
        let runs: Vec<_> = d.runs.iter().map(|r| pairs(r)).collect();
        assert_eq!(runs, vec![vec![("a", "1"), ("b", "x")], vec![("a", "2"), ("b", "y")], vec![("a", "3")]]);
        // Mixed with a single distribution before it: the multi varies fastest.
        let d = read_str(&file(&(set("s", &["p", "q"]) + multi))).expect("read");
        assert_eq!(d.runs.len(), 6);
        assert_eq!(pairs(&d.runs[0]), vec![("s", "p"), ("a", "1"), ("b", "x")]);
        assert_eq!(pairs(&d.runs[2]), vec![("s", "p"), ("a", "3")]);
        assert_eq!(pairs(&d.runs[3]), vec![("s", "q"), ("a", "1"), ("b", "x")]);
        // The same parameter in two distributions is an error.
        let e = read_str(&file(&(set("a", &["1"]) + multi))).expect_err("twice").to_string();
        assert!(e.contains("parameter `a` is already varied"), "{e}");
    }

    /// The permutations esmini 3.6.0 printed for this file (`--param_dist d.xosc
    /// --param_permutation i`, "Parameter permutation i+1/24" in its log), for i = 0, 4, 5, 23.
    #[test]
    fn matches_esmini_permutation_order() {
        let det = set("A", &["1", "2"])
            + r#"<DeterministicMultiParameterDistribution><ValueSetDistribution>
  <ParameterValueSet><ParameterAssignment parameterRef="B" value="10"/><ParameterAssignment parameterRef="C" value="100"/></ParameterValueSet>
  <ParameterValueSet><ParameterAssignment parameterRef="B" value="20"/><ParameterAssignment parameterRef="C" value="200"/></ParameterValueSet>
  <ParameterValueSet><ParameterAssignment parameterRef="B" value="30"/><ParameterAssignment parameterRef="C" value="300"/></ParameterValueSet>
</ValueSetDistribution></DeterministicMultiParameterDistribution>"#
            + &range_xml("B2", "0", "0.3", "0.1");
        let d = read_str(&file(&det)).expect("read");
        assert_eq!(d.runs.len(), 24);
        assert_eq!(pairs(&d.runs[0]), vec![("A", "1"), ("B", "10"), ("C", "100"), ("B2", "0")]);
        assert_eq!(pairs(&d.runs[4]), vec![("A", "1"), ("B", "20"), ("C", "200"), ("B2", "0")]);
        assert_eq!(pairs(&d.runs[5]), vec![("A", "1"), ("B", "20"), ("C", "200"), ("B2", "0.1")]);
        assert_eq!(pairs(&d.runs[23]), vec![("A", "2"), ("B", "30"), ("C", "300"), ("B2", "0.3")]);
    }

    #[test]
    fn huge_products_are_rejected_before_expansion() {
        let r = range_xml("a", "1", "1000", "1") + &range_xml("b", "1", "1000", "1") + &range_xml("c", "1", "1000", "1");
        let t = std::time::Instant::now();
        let e = read_str(&file(&r)).expect_err("too many").to_string();
        assert!(t.elapsed().as_secs_f64() < 0.5);
        assert!(e.contains("1000 x 1000 x 1000 = 1000000000 combinations, more than the limit of 100000"), "{e}");
        let many: String = (0..40).map(|i| set(&format!("p{i}"), &["1", "2", "3", "4", "5", "6", "7", "8", "9"])).collect();
        let e = read_str(&file(&many)).expect_err("overflow").to_string();
        assert!(e.contains("combinations"), "{e}");
        // Few runs, each repeating a huge value: refused by size.
        let huge = "x".repeat(2 * 1024 * 1024);
        let e = read_str(&file(&(range_xml("a", "1", "100", "1") + &set("b", &[&huge])))).expect_err("bytes").to_string();
        assert!(e.contains("bytes of parameter values"), "{e}");
    }

    #[test]
    fn errors() {
        let stoch = file("").replace("<Deterministic>\n\n    </Deterministic>", "<Stochastic numberOfTestRuns=\"3\"/>");
        let e = read_str(&stoch).expect_err("stochastic").to_string();
        assert!(e.contains("unsupported") && e.contains("Stochastic"), "{e}");
        let e = read_str(&file("")).expect_err("empty").to_string();
        assert!(e.contains("no distribution"), "{e}");
        let e = read_str(&file(&set("$a", &["1"]))).expect_err("dollar").to_string();
        assert!(e.contains("<DeterministicSingleParameterDistribution@parameterName>"), "{e}");
        let e = read_str(&file(&set("a", &[]))).expect_err("no element").to_string();
        assert!(e.contains("no <Element>"), "{e}");
        let e = read_str(&file(&set("a", &["$x"]))).expect_err("ref").to_string();
        assert!(e.contains("<Element@value>") && e.contains("parameter `x` is not declared"), "{e}");
        let udd = r#"<DeterministicSingleParameterDistribution parameterName="a"><UserDefinedDistribution type="t">x</UserDefinedDistribution></DeterministicSingleParameterDistribution>"#;
        assert!(read_str(&file(udd)).expect_err("udd").to_string().contains("unsupported"));
        let doc = xml::parse("<OpenSCENARIO><FileHeader/><Storyboard/></OpenSCENARIO>", "s").expect("xml");
        assert!(!is_distribution(&doc));
        assert!(read(&doc, Path::new("s")).is_err());
    }
}
