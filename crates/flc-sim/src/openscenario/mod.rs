//! Import of ASAM OpenSCENARIO XML 1.0-1.3 files (`.xosc`) and their OpenDRIVE roads (`.xodr`)
//! into the one [`crate::Scenario`] model (`docs/openscenario.md` lists the supported subset
//! element by element). Layer 3 (configuration): nothing below it knows XML exists.
//!
//! - [`xml`]: safe reading (size, node and depth limits, no DTD);
//! - [`error`]: [`ImportError`] (file, line, element, reason);
//! - [`expr`], [`params`]: parameters, `$name` and `${expr}`;
//! - [`road`]: OpenDRIVE plan view and lanes -> [`crate::Track`];
//! - [`distribution`]: `ParameterValueDistribution` files;
//! - `catalog`, `entities`, `position`, `storyboard`: catalogs, entities, positions, init and
//!   storyboard -> [`crate::Scenario`] ([`import`]).
//!
//! # Translation
//!
//! The ego becomes the follower, the lead (the simulator's V2V sender) is the nearest Vehicle
//! ahead of it in its lane at t = 0 (else the first other Vehicle, else the first MiscObject),
//! every other entity a `[[vehicles]]` entry; the storyboard becomes `[story]` (plus an act
//! `init` for the `Init` actions that take time) and its `StopTrigger` the scenario's
//! `stop.trigger`. Positions are converted from the OpenSCENARIO reference point to the box
//! centre flc places ([`EntityInfo::ref_offset`]) through world coordinates. Elements that change
//! neither motion nor sensing are skipped with one warning line per element kind
//! ([`Import::warnings`]); anything else that is not supported is an [`ImportError`].

mod catalog;
pub mod distribution;
mod entities;
pub mod error;
pub mod expr;
pub mod junction;
mod options;
pub mod params;
mod position;
pub mod road;
mod storyboard;
pub mod xml;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub use error::ImportError;

use crate::controllers::ControllerKind;
use crate::lead::{LeadSpec, ScriptedVehicle};
use crate::scenario::{KMH, Scenario, TrackSpec};
use crate::story::{Action, Dynamics, EgoMode, Story, Variable};
use crate::trigger::VarValue;
use catalog::{CatalogFiles, Catalogs};
use entities::{EntityDef, Kind, Placement};
use params::Params;
use position::{Geo, Pose};
use storyboard::{Facts, Sb};

type Node<'a, 'i> = roxmltree::Node<'a, 'i>;

/// Which road an imported scenario drives on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RoadChoice {
    /// The `RoadNetwork/LogicFile` (a straight road if there is none). Default.
    #[default]
    File,
    /// A straight road along +x from (0, 0), 4 right lanes (-1 .. -4) of 3.5 m, 5 km long,
    /// whatever the file names (`--road straight`); every `roadId` names it.
    Straight,
}

/// Options of [`import`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ImportOptions {
    /// Parameter values (`--param NAME=VALUE`), overriding the declared ones (an undeclared
    /// name is an error).
    pub params: Vec<(String, String)>,
    /// The entity that is the ego (`--ego`; default: `Ego`, `ego`, else the first).
    pub ego: Option<String>,
    /// Who drives the ego (`--ego-mode`).
    pub ego_mode: EgoMode,
    /// The controller (`--controllers`); default: the one the file's ego controller names, else
    /// the scenario default.
    pub controller: Option<ControllerKind>,
    /// The road.
    pub road: RoadChoice,
    /// How the scripted entities move (`--traffic-dynamics`).
    pub dynamics: Dynamics,
    /// `--strict`: what esmini accepts but the standard does not (its expression extensions
    /// such as `pi` and `sin`, a negative dynamics value, a value its declaration's
    /// `ValueConstraint`s forbid) is an error instead of a warning.
    pub strict: bool,
    /// The guard on a run's length, s (`--max-duration`; `None`: [`DEFAULT_MAX_DURATION`]):
    /// the scenario's `duration`. The file's `StopTrigger` ends a run before it.
    pub max_duration: Option<f64>,
}

/// How an OpenSCENARIO entity appears in the scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct EntityInfo {
    /// Its OpenSCENARIO name.
    pub osc_name: String,
    /// Its scenario name: `ego`, `lead` or the vehicle name (a reserved name gets a suffix).
    pub flc_name: String,
    /// `BoundingBox/Center` x, y, m: the OpenSCENARIO reference point is this far behind
    /// (x) and to the right (y) of the box centre flc places.
    pub ref_offset: [f64; 2],
    /// Box length, m.
    pub length: f64,
    /// Box width, m.
    pub width: f64,
}

/// One imported run.
#[derive(Debug, Clone, PartialEq)]
pub struct Imported {
    /// The scenario.
    pub scenario: Scenario,
    /// The parameter values of this run: a distribution's combination, else the given
    /// overrides.
    pub params: Vec<(String, String)>,
    /// The same values typed by their declarations ([`params::Param::to_json`]: numbers,
    /// integers, booleans, text), in the order of `params`.
    pub typed_params: Vec<(String, serde_json::Value)>,
    /// The entities, in file order.
    pub entities: Vec<EntityInfo>,
}

/// The result of [`import`].
#[derive(Debug, Clone, PartialEq)]
pub struct Import {
    /// One run, or one per combination of a distribution file (`variant` = `p0`, `p1`, ...).
    pub runs: Vec<Imported>,
    /// One line per kind of skipped element or approximation (`FILE:LINE: <Element>: ...`).
    pub warnings: Vec<String>,
}

/// Warning lines, one per key (element kind), the first occurrence kept.
#[derive(Debug, Clone, Default)]
pub(crate) struct Warnings(BTreeMap<String, String>);

impl Warnings {
    /// `node` (of `file`) is skipped: `reason`.
    pub(crate) fn skip(&mut self, file: &str, node: Node<'_, '_>, reason: &str) {
        let tag = node.tag_name().name().to_string();
        let line = format!("{file}:{}: <{tag}>: skipped ({reason})", xml::line(node));
        self.0.entry(tag).or_insert(line);
    }

    /// A note about `key` at `node`.
    pub(crate) fn note(&mut self, key: &str, file: &str, node: Node<'_, '_>, message: String) {
        let line = format!("{file}:{}: <{key}>: {message}", xml::line(node));
        self.0.entry(key.to_string()).or_insert(line);
    }

    /// A note about `key` without a node.
    pub(crate) fn line(&mut self, key: &str, line: String) {
        self.0.entry(key.to_string()).or_insert(line);
    }

    fn into_lines(self) -> Vec<String> {
        self.0.into_values().collect()
    }
}

/// Elements skipped with a warning wherever they appear: they change neither motion nor
/// sensing in flc.
const SKIPPED: [(&str, &str); 21] = [
    ("FileHeader", "metadata"),
    ("License", "metadata"),
    ("Properties", "other tools' properties"),
    ("Property", "other tools' properties"),
    ("File", "other tools' properties"),
    ("Environment", "environment: changes neither motion nor sensing in flc"),
    ("Weather", "environment: changes neither motion nor sensing in flc"),
    ("RoadCondition", "environment: changes neither motion nor sensing in flc"),
    ("TimeOfDay", "environment: changes neither motion nor sensing in flc"),
    ("Fog", "environment: changes neither motion nor sensing in flc"),
    ("Precipitation", "environment: changes neither motion nor sensing in flc"),
    ("Sun", "environment: changes neither motion nor sensing in flc"),
    ("Wind", "environment: changes neither motion nor sensing in flc"),
    ("SceneGraphFile", "visual model"),
    ("TrafficSignals", "no traffic signals in flc"),
    ("TrafficSignalController", "no traffic signals in flc"),
    ("UsedArea", "metadata"),
    ("Axles", "not used"),
    ("Performance", "not used"),
    ("VisibilityAction", "visual only"),
    ("AppearanceAction", "visual only"),
];

/// The importer's state while one scenario is translated: parameters in scope, catalogs,
/// warnings and the stack of catalog references being expanded.
pub(crate) struct Ctx<'a, 't> {
    pub(crate) params: Params,
    pub(crate) cats: &'a Catalogs<'t>,
    pub(crate) warn: Warnings,
    stack: Vec<(String, String)>,
    /// The last vehicle `Performance` read: `[maxAcceleration, maxDeceleration]` when both are
    /// given and used.
    pub(crate) performance: Option<[f64; 2]>,
}

impl<'a, 't> Ctx<'a, 't> {
    /// An element not handled where it is: skipped with a warning if it changes neither motion
    /// nor sensing ([`SKIPPED`]), else an error.
    pub(crate) fn other(&mut self, file: &str, node: Node<'_, '_>) -> Result<(), ImportError> {
        match SKIPPED.iter().find(|(n, _)| *n == node.tag_name().name()) {
            Some((_, reason)) => {
                self.warn.skip(file, node, reason);
                Ok(())
            }
            None => Err(ImportError::unsupported(file, node)),
        }
    }

    /// `node` uses what esmini accepts but OpenSCENARIO does not (`what`): with `--strict` an
    /// error, else one warning line per `key` saying that flc plays it as esmini does (`how`).
    pub(crate) fn esmini_extension(&mut self, key: &str, file: &str, node: Node<'_, '_>, what: &str, how: &str) -> Result<(), ImportError> {
        if self.params.strict() {
            return Err(ImportError::at(file, node, format!("{what}: not OpenSCENARIO, accepted by esmini only (refused with --strict)")));
        }
        self.warn.note(key, file, node, format!("{what}: not OpenSCENARIO; {how}, as esmini does (--strict refuses it)"));
        Ok(())
    }

    /// Enters catalog entry `catalog`/`entry` referenced at `node`: a reference cycle or
    /// nesting deeper than [`catalog::MAX_DEPTH`] is an error.
    pub(crate) fn enter_catalog(&mut self, file: &str, node: Node<'_, '_>, catalog: &str, entry: &str) -> Result<(), ImportError> {
        let key = (catalog.to_string(), entry.to_string());
        if self.stack.contains(&key) {
            let chain: Vec<String> = self.stack.iter().chain(std::iter::once(&key)).map(|(c, e)| format!("{c}/{e}")).collect();
            return Err(ImportError::at(file, node, format!("catalog reference cycle: {}", chain.join(" -> "))));
        }
        if self.stack.len() >= catalog::MAX_DEPTH {
            return Err(ImportError::at(file, node, format!("catalog references nested deeper than {}", catalog::MAX_DEPTH)));
        }
        self.stack.push(key);
        Ok(())
    }

    /// Leaves the innermost catalog entry.
    pub(crate) fn leave_catalog(&mut self) {
        self.stack.pop();
    }

    /// Runs `f` on the entry a `CatalogReference` (`reference`, of `file`) names, with the
    /// entry's `ParameterDeclarations` in a new scope (the reference's `ParameterAssignments`
    /// override them). `kinds`: the catalog location kinds searched first.
    pub(crate) fn catalog_entry<R>(
        &mut self,
        file: &str,
        reference: Node<'_, '_>,
        kinds: &[&str],
        f: impl FnOnce(&mut Self, &str, Node<'a, 't>) -> Result<R, ImportError>,
    ) -> Result<R, ImportError> {
        let catalog = self.params.req_str(reference, "catalogName", file)?;
        let entry = self.params.req_str(reference, "entryName", file)?;
        let overrides = catalog::assignments(&self.params, reference, file)?;
        let cats = self.cats;
        let (efile, node) =
            cats.find(kinds, &catalog, &entry)?.ok_or_else(|| ImportError::at(file, reference, cats.not_found(&catalog, &entry)))?;
        self.enter_catalog(file, reference, &catalog, &entry)?;
        self.params.push_scope();
        let r = self.params.declare_in(node, &efile, &overrides).and_then(|()| f(self, &efile, node));
        self.params.pop_scope();
        self.leave_catalog();
        r
    }
}

/// Road files read so far (a distribution's runs share them; runs imported in parallel share
/// the cache).
#[derive(Default)]
struct Roads(std::sync::Mutex<BTreeMap<PathBuf, std::sync::Arc<road::Network>>>);

impl Roads {
    fn load(&self, path: &Path) -> Result<std::sync::Arc<road::Network>, ImportError> {
        let cached = self.0.lock().ok().and_then(|m| m.get(path).cloned());
        if let Some(net) = cached {
            return Ok(net);
        }
        let net = std::sync::Arc::new(road::load(path)?);
        if let Ok(mut m) = self.0.lock() {
            m.insert(path.to_path_buf(), net.clone());
        }
        Ok(net)
    }
}

/// The default of [`ImportOptions::max_duration`], s: the guard that ends a run whose
/// `StopTrigger` has not fired (`--max-duration`).
pub const DEFAULT_MAX_DURATION: f64 = 3600.0;

/// An OpenSCENARIO file opened for import: a scenario (one run) or a `ParameterValueDistribution`
/// (one run per combination), each run imported on demand ([`Source::run`]) so that a file of
/// any number of runs costs one run's memory at a time. Runs may be imported in parallel
/// (`Source` is `Sync`).
pub struct Source {
    /// The scenario file (the distribution's `ScenarioFile`) and its text.
    scenario_file: PathBuf,
    text: String,
    /// The distribution, if the file is one.
    dist: Option<distribution::Distribution>,
    opts: ImportOptions,
    roads: Roads,
    /// Warnings of reading the distribution file itself.
    opening: Warnings,
}

impl Source {
    /// Opens `path`: reads it (and a distribution's scenario file) and checks the distribution,
    /// expanding nothing. Errors name the file, line and element.
    pub fn open(path: &Path, opts: &ImportOptions) -> Result<Self, ImportError> {
        if let Some(d) = opts.max_duration {
            if !(d.is_finite() && (0.01..=crate::scenario::MAX_DURATION).contains(&d)) {
                return Err(ImportError::file(
                    &path.display().to_string(),
                    format!("max_duration must be in [0.01, {}] s, got {d}", crate::scenario::MAX_DURATION),
                ));
            }
        }
        let origin = path.display().to_string();
        let text = xml::read(path)?;
        let doc = xml::parse(&text, &origin)?;
        if !distribution::is_distribution(&doc) {
            return Ok(Self {
                scenario_file: path.to_path_buf(),
                text,
                dist: None,
                opts: opts.clone(),
                roads: Roads::default(),
                opening: Warnings::default(),
            });
        }
        let mut warn = Warnings::default();
        for c in xml::elements(doc.root_element()) {
            if c.tag_name().name() == "FileHeader" {
                file_header(&origin, c)?;
                warn.skip(&origin, c, "metadata");
            }
        }
        let dist = distribution::read(&doc, path)?;
        let stext = xml::read(&dist.scenario_file)?;
        let sorigin = dist.scenario_file.display().to_string();
        let sdoc = xml::parse(&stext, &sorigin)?;
        if distribution::is_distribution(&sdoc) {
            return Err(ImportError::file(&sorigin, "the ScenarioFile of a distribution is itself a distribution"));
        }
        drop(sdoc);
        Ok(Self {
            scenario_file: dist.scenario_file.clone(),
            text: stext,
            dist: Some(dist),
            opts: opts.clone(),
            roads: Roads::default(),
            opening: warn,
        })
    }

    /// The number of runs: 1, or the distribution's number of combinations.
    pub fn len(&self) -> usize {
        self.dist.as_ref().map_or(1, distribution::Distribution::len)
    }

    /// Never `true` (a file has at least one run).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether the file is a `ParameterValueDistribution`.
    pub fn is_distribution(&self) -> bool {
        self.dist.is_some()
    }

    /// The options the runs are imported with.
    pub fn options(&self) -> &ImportOptions {
        &self.opts
    }

    /// Run `i` (0-based; esmini's `--param_permutation i` for a distribution) with the warning
    /// lines its import gave (those of reading the distribution file first). `i` out of range
    /// is an error naming `permutation` and the number of runs.
    pub fn run(&self, i: usize) -> Result<(Imported, Vec<String>), ImportError> {
        let mut warn = self.opening.clone();
        let imp = self.run_into(i, &mut warn)?;
        Ok((imp, warn.into_lines()))
    }

    fn run_into(&self, i: usize, warn: &mut Warnings) -> Result<Imported, ImportError> {
        let n = self.len();
        if i >= n {
            return Err(ImportError::file(
                &self.scenario_file.display().to_string(),
                format!("permutation {i} does not exist: the file has {n} run(s), permutations 0-{}", n.saturating_sub(1)),
            ));
        }
        let origin = self.scenario_file.display().to_string();
        let doc = xml::parse(&self.text, &origin)?;
        let Some(dist) = &self.dist else {
            return import_doc(&doc, &self.scenario_file, &self.opts.params, &self.opts, warn, &self.roads);
        };
        let run = dist.run(i).unwrap_or_default();
        let mut params = run.clone();
        for (k, v) in &self.opts.params {
            match params.iter_mut().find(|(n, _)| n == k) {
                Some(slot) => slot.1 = v.clone(),
                None => params.push((k.clone(), v.clone())),
            }
        }
        let mut imp = import_doc(&doc, &self.scenario_file, &params, &self.opts, warn, &self.roads)?;
        // The run's name says its parameters (table, JSON `variant`, file names).
        let values: Vec<String> = run.iter().map(|(k, v)| format!("{k}={v}")).collect();
        imp.scenario.variant = Some(format!("p{i} {}", values.join(" ")));
        imp.params = params;
        Ok(imp)
    }
}

/// Imports the OpenSCENARIO file `path`: a scenario, or a `ParameterValueDistribution` (one run
/// per combination, all of them built: for large files use [`Source`], which builds one at a
/// time). Every problem is an [`ImportError`] naming the file, line and element.
pub fn import(path: &Path, opts: &ImportOptions) -> Result<Import, ImportError> {
    let src = Source::open(path, opts)?;
    let mut warn = src.opening.clone();
    let runs = (0..src.len()).map(|i| src.run_into(i, &mut warn)).collect::<Result<Vec<_>, _>>()?;
    Ok(Import { runs, warnings: warn.into_lines() })
}

/// Limits checked before anything is built: entities, storyboard elements, conditions per
/// trigger.
fn check_limits(file: &str, entities: Node<'_, '_>, storyboard: Node<'_, '_>) -> Result<(), ImportError> {
    let n = xml::elements(entities).count();
    if n > entities::MAX_ENTITIES {
        return Err(ImportError::at(file, entities, format!("{n} entities, more than the limit of {}", entities::MAX_ENTITIES)));
    }
    let is = |d: &Node<'_, '_>, names: &[&str]| d.is_element() && names.contains(&d.tag_name().name());
    let m = storyboard.descendants().filter(|d| is(d, &["Act", "ManeuverGroup", "Maneuver", "Event", "Action"])).count();
    if m > crate::story::MAX_ELEMENTS {
        return Err(ImportError::at(
            file,
            storyboard,
            format!("{m} storyboard elements, more than the limit of {}", crate::story::MAX_ELEMENTS),
        ));
    }
    for t in storyboard.descendants().filter(|d| is(d, &["StartTrigger", "StopTrigger"])) {
        let c = t.descendants().filter(|d| is(d, &["Condition"])).count();
        if c > storyboard::MAX_CONDITIONS {
            return Err(ImportError::at(
                file,
                t,
                format!("{c} conditions, more than the limit of {} per trigger", storyboard::MAX_CONDITIONS),
            ));
        }
    }
    Ok(())
}

/// The road the ego's initial position names (following relative positions), if any.
fn road_hint(
    ctx: &mut Ctx<'_, '_>,
    file: &str,
    ego: usize,
    init: &[storyboard::InitState<'_, '_>],
    names: &[String],
) -> Result<Option<String>, ImportError> {
    let mut i = ego;
    for _ in 0..=names.len() {
        let st = init.get(i);
        if let Some(fta) = st.and_then(|s| s.trajectory).filter(|_| st.is_some_and(|s| s.position.is_none())) {
            return storyboard::trajectory_start(ctx, file, fta, |ctx, file, pos, _| match pos.first() {
                Some(p) => position::road_id(&ctx.params, file, *p),
                None => Ok(None),
            });
        }
        let Some(pos) = st.and_then(|s| s.position) else { return Ok(None) };
        if let Some(id) = position::road_id(&ctx.params, file, pos)? {
            return Ok(Some(id));
        }
        match position::reference(&ctx.params, file, pos)? {
            Some(r) => match names.iter().position(|n| *n == r) {
                Some(j) => i = j,
                None => return Ok(None),
            },
            None => return Ok(None),
        }
    }
    Ok(None)
}

/// The road positions refer to: `road` alone, or, in a network of several roads, the ego's
/// route through it from `road` ([`junction::route`], joined into one road). The route follows
/// the ego's lane, found from its Init position (`position`, resolved on `road` alone; lane -1
/// if that position is relative to another entity); a lane with a positive id keeps the one road.
fn ego_route(
    ctx: &mut Ctx<'_, '_>,
    file: &str,
    net: &road::Network,
    road: &road::Road,
    position: Option<roxmltree::Node<'_, '_>>,
) -> Result<Geo, ImportError> {
    let alone = Geo { road: road.clone(), any_road: false, route: None };
    if net.roads.len() < 2 {
        return Ok(alone);
    }
    let none = |_: &str| None;
    let lane = position
        .and_then(|p| position::resolve(&ctx.params, &alone, file, p, &none).ok())
        .and_then(|pose| {
            let (s, t) = road.to_local(pose.x, pose.y);
            road.lane_at(s, t)
        })
        .unwrap_or(-1);
    if lane > 0 {
        ctx.warn.line("roads", format!("{file}: only road `{}` of the road file's {} roads is used", road.id, net.roads.len()));
        return Ok(alone);
    }
    let route = junction::route(net, road, lane)?;
    let joined = junction::join(net, &route, lane)?;
    ctx.warn.line(
        "roads",
        format!(
            "{file}: the ego's route through the road file's {} roads: {} (other roads are not used)",
            net.roads.len(),
            route.describe()
        ),
    );
    Ok(Geo { road: joined, any_road: false, route: Some(route) })
}

/// Translates one scenario document (`doc`, read from `path`) with parameter values `values`.
fn import_doc(
    doc: &roxmltree::Document<'_>,
    path: &Path,
    values: &[(String, String)],
    opts: &ImportOptions,
    warn: &mut Warnings,
    roads: &Roads,
) -> Result<Imported, ImportError> {
    let file = path.display().to_string();
    let file = file.as_str();
    let root = doc.root_element();
    if root.tag_name().name() != "OpenSCENARIO" {
        return Err(ImportError::at(file, root, "not an OpenSCENARIO file: the root element must be <OpenSCENARIO>"));
    }
    let base = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let (mut vars, mut locations, mut network, mut entities, mut board) = (None, None, None, None, None);
    for c in xml::elements(root) {
        match c.tag_name().name() {
            "FileHeader" => {
                file_header(file, c)?;
                warn.skip(file, c, "metadata");
            }
            "ParameterDeclarations" => {}
            "VariableDeclarations" => vars = Some(c),
            "CatalogLocations" => locations = Some(c),
            "RoadNetwork" => network = Some(c),
            "Entities" => entities = Some(c),
            "Storyboard" => board = Some(c),
            "Catalog" => return Err(ImportError::at(file, c, "this is a catalog file, not a scenario")),
            _ => return Err(ImportError::unsupported(file, c)),
        }
    }
    let entities = entities.ok_or_else(|| ImportError::at(file, root, "<Entities> is missing"))?;
    let board = board.ok_or_else(|| ImportError::at(file, root, "<Storyboard> is missing"))?;
    check_limits(file, entities, board)?;

    let overrides: BTreeMap<String, String> = values.iter().cloned().collect();
    let mut params = Params::new();
    params.set_strict(opts.strict);
    let declared = params.declare_in(root, file, &overrides);
    for (k, l) in params.take_notes() {
        warn.line(&k, l);
    }
    declared?;
    let files = match locations {
        Some(l) => CatalogFiles::list(l, &base, &params, file)?,
        None => CatalogFiles::empty(),
    };
    let cats = Catalogs::new(&files);
    let mut ctx = Ctx { params, cats: &cats, warn: std::mem::take(warn), stack: Vec::new(), performance: None };
    let r = translate(&mut ctx, doc, file, &base, (vars, network, entities, board), opts, roads).map(|mut imp| {
        // The given values typed by their declarations (an undeclared one stays text).
        imp.typed_params = values
            .iter()
            .map(|(n, text)| (n.clone(), ctx.params.get(n).map_or_else(|| serde_json::Value::String(text.clone()), params::Param::to_json)))
            .collect();
        imp
    });
    for (k, l) in ctx.params.take_notes() {
        ctx.warn.line(&k, l);
    }
    *warn = std::mem::take(&mut ctx.warn);
    r
}

type Parts<'a, 'i> = (Option<Node<'a, 'i>>, Option<Node<'a, 'i>>, Node<'a, 'i>, Node<'a, 'i>);

fn translate(
    ctx: &mut Ctx<'_, '_>,
    doc: &roxmltree::Document<'_>,
    file: &str,
    base: &Path,
    (vars, network, entities, board): Parts<'_, '_>,
    opts: &ImportOptions,
    roads: &Roads,
) -> Result<Imported, ImportError> {
    let root = doc.root_element();
    let stem = Path::new(file).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();

    // The road network.
    let mut logic = None;
    if let Some(n) = network {
        for c in xml::elements(n) {
            match c.tag_name().name() {
                "LogicFile" => logic = Some(c),
                _ => ctx.other(file, c)?,
            }
        }
    }
    let net = match (opts.road, logic) {
        (RoadChoice::Straight, Some(l)) => {
            ctx.warn.note("LogicFile", file, l, "not read: --road straight (a straight road of 4 lanes of 3.5 m)".into());
            None
        }
        (RoadChoice::Straight, None) => None,
        (RoadChoice::File, None) => {
            ctx.warn.note(
                "RoadNetwork",
                file,
                network.unwrap_or(root),
                "no LogicFile: a straight road of 4 lanes of 3.5 m along +x".into(),
            );
            None
        }
        (RoadChoice::File, Some(l)) => {
            let fp = ctx.params.req_str(l, "filepath", file)?;
            let joined = base.join(fp.trim());
            let canon = joined.canonicalize().map_err(|e| ImportError::at(file, l, format!("road file `{fp}`: {e}")))?;
            let net = roads.load(&canon)?;
            for tag in &net.skipped {
                ctx.warn.line(&format!("xodr:{tag}"), format!("{}: <{tag}>: skipped (does not change 2-D motion)", canon.display()));
            }
            Some((*net).clone())
        }
    };

    // Entities, the ego and the init state.
    let defs = ctx.read_entities(file, entities)?;
    let ego = entities::choose_ego(&defs, opts.ego.as_deref()).map_err(|m| ImportError::at(file, entities, m))?;
    for (i, d) in defs.iter().enumerate() {
        if i != ego && d.controller.is_some() {
            ctx.warn.line(
                "ObjectController",
                format!(
                    "{}:{}: <ObjectController>: of `{}`, not the ego: not used (scripted entities follow the story)",
                    d.file, d.line, d.osc_name
                ),
            );
        }
    }
    let osc_names: Vec<String> = defs.iter().map(|d| d.osc_name.clone()).collect();
    let init = xml::child(board, "Init").ok_or_else(|| ImportError::at(file, board, "<Init> is missing"))?;
    let init_states = storyboard::init_state(ctx, file, init, &osc_names)?;
    let init_controller = init_controller(ctx, file, init, &osc_names, ego)?;

    // The road and the positions.
    let geo = match &net {
        None => Geo::straight(4, 3.5, 5000.0)?,
        Some(n) => {
            let id = road_hint(ctx, file, ego, &init_states, &osc_names)?;
            let road = match id {
                Some(id) => n.road(id.trim()).ok_or_else(|| {
                    let at = init_states.get(ego).and_then(|s| s.position).unwrap_or(root);
                    ImportError::at(file, at, format!("road `{id}` is not in the road file"))
                })?,
                None => n.roads.first().ok_or_else(|| ImportError::at(file, root, "the road file has no road"))?,
            };
            match init_states.get(ego).filter(|s| s.position.is_none()).and_then(|s| s.trajectory) {
                Some(fta) => {
                    storyboard::trajectory_start(ctx, file, fta, |ctx, file, pos, _| ego_route(ctx, file, n, road, pos.first().copied()))?
                }
                None => ego_route(ctx, file, n, road, init_states.get(ego).and_then(|s| s.position))?,
            }
        }
    };
    let poses = place_all(ctx, file, &geo, &defs, &init_states, &osc_names)?;
    let ego_pose = poses.get(ego).copied().unwrap_or_default();
    let (es, et) = geo.road.to_local(ego_pose.x, ego_pose.y);
    let ego_lane = geo.road.lane_at(es, et).ok_or_else(|| {
        ImportError::at(
            file,
            init_states.get(ego).and_then(|s| s.position).unwrap_or(root),
            format!("the ego is not in a lane of road `{}`", geo.road.id),
        )
    })?;
    let (track, lanes) = road::to_track(&geo.road, ego_lane, &stem)?;
    if let Some(note) = &lanes.note {
        ctx.warn.line("lanes", format!("{file}: lanes of road `{}`: {note}", geo.road.id));
    }
    let (lo, hi) = crate::track::USUAL_LANE_WIDTH;
    if track.lane_width < lo || track.lane_width > hi {
        ctx.warn.line(
            "lane_width",
            format!(
                "{file}: lane {ego_lane} of road `{}` is {} m wide, outside the usual {lo}-{hi} m of a road (a test track?): taken as it is",
                geo.road.id, track.lane_width
            ),
        );
    }
    let placed: Vec<Placement> = defs
        .iter()
        .zip(&poses)
        .map(|(d, p)| {
            let c = p.offset(d.center[0], d.center[1]);
            let pr = track.project(c.x, c.y);
            Placement { s: pr.s, lateral: pr.lateral_offset, heading: crate::track::wrap(p.h - pr.heading) }
        })
        .collect();
    // A vehicle facing more than 90° away from the road's direction (an oncoming one, e.g. heading
    // pi) drives against it: `s` decreasing (`Motion::reversed`).
    // No entity to take as the lead (the ego alone): the lead is absent (`LeadSpec::absent`).
    let lead = entities::choose_lead(&defs, &placed, ego, track.lane_width);
    let names = entities::flc_names(&defs, ego, lead.unwrap_or(usize::MAX));

    // The scenario's entities.
    let mut s = Scenario { name: stem.clone(), duration: opts.max_duration.unwrap_or(DEFAULT_MAX_DURATION), ..Scenario::default() };
    if opts.ego_mode == EgoMode::Scripted {
        // The file ends the run (its StopTrigger, else the max-duration guard), as in esmini:
        // contacts are reported and the run goes on.
        s.stop.on_collision = false;
        s.stop.on_standstill = false;
    }
    let speed_of = |i: usize| init_states.get(i).and_then(|st| st.speed).unwrap_or(0.0);
    for (i, d) in defs.iter().enumerate() {
        if d.kind == Kind::Misc && speed_of(i) != 0.0 {
            let at = init_states.get(i).and_then(|st| st.position).unwrap_or(entities);
            return Err(ImportError::at(file, at, format!("`{}` is a MiscObject: it cannot have a speed", d.osc_name)));
        }
    }
    let (Some(ed), Some(ep)) = (defs.get(ego), placed.get(ego)) else {
        return Err(ImportError::at(file, entities, "no ego"));
    };
    s.follower.vehicle = ed.vehicle;
    s.follower.start_s = Some(ep.s);
    s.follower.start_offset = ep.lateral;
    s.follower.start_heading = ep.heading;
    s.follower.initial_speed = speed_of(ego);
    if lead.is_none() {
        // The ego alone (free driving): no lead, nothing in front, no V2V.
        s.lead = LeadSpec { absent: true, s: Some(ep.s), offset: ep.lateral, ..LeadSpec::default() };
        s.v2v.enabled = false;
    }
    s.follower.lane_keeping = crate::FollowerSpec::default_lane_keeping(crate::ScenarioOrigin::OpenScenario);
    for (i, (d, p)) in defs.iter().zip(&placed).enumerate() {
        if i == ego {
            continue;
        }
        let name = names.get(i).cloned().unwrap_or_default();
        if Some(i) == lead {
            s.lead = LeadSpec {
                initial_speed: speed_of(i),
                vehicle: d.vehicle,
                phases: Vec::new(),
                s: Some(p.s),
                offset: p.lateral,
                heading: p.heading,
                absent: false,
            };
        } else {
            s.vehicles.push(ScriptedVehicle {
                name,
                vehicle: d.vehicle,
                s: p.s,
                lane: None,
                offset: Some(p.lateral),
                heading: p.heading,
                initial_speed: speed_of(i),
                phases: Vec::new(),
            });
        }
    }

    // The storyboard.
    let name_map: BTreeMap<String, String> = osc_names.iter().cloned().zip(names.iter().cloned()).collect();
    let facts: BTreeMap<String, Facts> = defs
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let pose = poses.get(i).copied().unwrap_or_default();
            let road_s = geo.road.to_local(pose.x, pose.y).0;
            (names.get(i).cloned().unwrap_or_default(), Facts { center: d.center, road_s, misc: d.kind == Kind::Misc, ego: i == ego })
        })
        .collect();
    let variables = match vars {
        Some(v) => ctx.params.read_variables(v, file)?.iter().map(|(n, v)| (n.clone(), storyboard::var_value(v))).collect(),
        None => Vec::new(),
    };
    let mut sb = Sb {
        ctx,
        names: &name_map,
        facts: &facts,
        geo: &geo,
        track: &track,
        lanes: &lanes,
        ego_mode: opts.ego_mode,
        variables,
        param_vars: BTreeMap::new(),
        skipped_used: false,
        elements: 0,
        start_trajectory: false,
        start_offset: 0.0,
    };
    let init_act = sb.init_act(file, init)?;
    let (story_acts, stop) = sb.storyboard(file, board)?;
    let mut acts: Vec<crate::story::Act> = init_act.into_iter().collect();
    acts.extend(story_acts);
    let mut variables: Vec<Variable> = sb.variables.iter().map(|(n, v)| Variable { name: n.clone(), value: v.clone() }).collect();
    variables.extend(sb.param_vars.iter().map(|(n, v)| Variable { name: n.clone(), value: v.clone() }));
    if sb.skipped_used {
        variables.push(Variable { name: storyboard::SKIPPED_VAR.into(), value: VarValue::Num(0.0) });
    }
    // Every entity's reference point: its actions move that point, as in OpenSCENARIO.
    let references = defs.iter().zip(&names).filter(|(d, _)| d.center != [0.0, 0.0]).map(|(d, n)| (n.clone(), d.center)).collect();
    // A vehicle's Performance limits its speed changes (esmini); a pedestrian's or an object's
    // do not. Recorded for the vehicles it may bind: a speed change by time or distance, or by a
    // rate whose peak exceeds the smaller limit (a step, or a rate within both, never needs it).
    let may_bind = |name: &str, [up, down]: [f64; 2]| {
        acts.iter().flat_map(|a| a.groups.iter()).filter(|g| g.actors.iter().any(|x| x == name)).any(|g| {
            g.maneuvers.iter().flat_map(|m| m.events.iter()).flat_map(|e| e.actions.iter()).any(|x| match &x.action {
                crate::story::Action::Speed { transition: t, .. } => {
                    t.shape != crate::story::Shape::Step
                        && (t.dimension != crate::story::Dimension::Rate || t.shape.peak_slope() * t.value > up.min(down))
                }
                _ => false,
            })
        })
    };
    let limits = defs
        .iter()
        .zip(&names)
        .filter_map(|(d, n)| d.performance.filter(|&p| d.kind == entities::Kind::Vehicle && may_bind(n, p)).map(|p| (n.clone(), p)))
        .collect();
    let story = Story { dynamics: opts.dynamics, ego: opts.ego_mode, variables, references, limits, acts };

    // The controller and its set speed.
    let kind = opts.controller.or(init_controller).or(ed.controller).unwrap_or_default();
    s.set_controller(kind);
    if s.v2v.enabled && s.lead.vehicle.body == crate::vehicle::BodyKind::Pedestrian {
        // A pedestrian sends no V2V: the follower has its LiDAR only.
        s.v2v.enabled = false;
        let lead_name = lead.and_then(|l| defs.get(l)).map(|d| d.osc_name.as_str()).unwrap_or_default();
        ctx.warn.line("pedestrian-v2v", format!("{file}: the lead `{lead_name}` is a Pedestrian: it sends no V2V (v2v.enabled = false)"));
    }
    let mut top = (0..defs.len()).map(speed_of).fold(0.0_f64, f64::max);
    for a in &story.acts {
        for g in &a.groups {
            for m in &g.maneuvers {
                for e in &m.events {
                    for x in &e.actions {
                        if let Action::Speed { speed: Some(v), .. } = x.action {
                            top = top.max(v);
                        }
                    }
                }
            }
        }
    }
    if top > 0.0 {
        set_cruise_speed(&mut s, top + crate::paper::BASELINE_SET_SPEED_MARGIN_KMH * KMH);
    }
    let ego_speed = speed_of(ego);
    if ego_speed > 0.0 {
        // The careful driver drives the ego's speed, as esmini's R157 ReferenceDriver keeps the
        // speed it has when it takes over (its `set_speed_`): the scenario's driver, not an ACC.
        let mut sec = s.sections();
        ControllerKind::CarefulDriver.set_cruise_speed(&mut sec, ego_speed);
        s.set_sections(sec);
    }
    s.track = TrackSpec::Custom(track);
    s.stop.trigger = stop;
    s.story = Some(story);
    s.validate().map_err(|e| ImportError::at(file, root, format!("the imported scenario is invalid: {e}")))?;

    let infos = defs
        .iter()
        .zip(&names)
        .map(|(d, n)| EntityInfo {
            osc_name: d.osc_name.clone(),
            flc_name: n.clone(),
            ref_offset: d.center,
            length: d.vehicle.length,
            width: d.vehicle.width,
        })
        .collect();
    // `import_doc` fills `typed_params` from the values it was given.
    Ok(Imported { scenario: s, params: opts.params.clone(), typed_params: Vec::new(), entities: infos })
}

/// `FileHeader`: metadata, but `revMajor` and `revMinor` (required) must be whole numbers in
/// [0, 65535] (`unsignedShort`: NaN, infinities and text are errors). A parameter reference is
/// left alone (a header is read before the parameters).
fn file_header(file: &str, node: Node<'_, '_>) -> Result<(), ImportError> {
    for a in ["revMajor", "revMinor"] {
        let raw = node.attribute(a).ok_or_else(|| ImportError::at(file, node, format!("missing attribute `{a}`")))?;
        if raw.trim().starts_with('$') {
            continue;
        }
        if raw.trim().parse::<u16>().is_err() {
            let mut e = ImportError::at(file, node, format!("`{raw}` is not an unsignedShort (a whole number in 0-65535)"));
            e.element = format!("{}@{a}", e.element);
            return Err(e);
        }
    }
    Ok(())
}

/// The cruise controllers' set speed (m/s): the baselines are cruise controllers and follow the
/// lead only below it (as in the paper experiment, 20 km/h above the fastest speed of the file).
fn set_cruise_speed(s: &mut Scenario, v: f64) {
    let mut sec = s.sections();
    for k in ControllerKind::ALL {
        k.set_cruise_speed(&mut sec, v);
    }
    s.set_sections(sec);
}

/// The flc controller an `AssignControllerAction` in Init names for the ego, if any.
fn init_controller(
    ctx: &mut Ctx<'_, '_>,
    file: &str,
    init: Node<'_, '_>,
    names: &[String],
    ego: usize,
) -> Result<Option<ControllerKind>, ImportError> {
    let Some(ego_name) = names.get(ego) else { return Ok(None) };
    let mut found = None;
    for actions in xml::elements(init) {
        for p in xml::children(actions, "Private") {
            if ctx.params.req_str(p, "entityRef", file)? != *ego_name {
                continue;
            }
            for pa in xml::elements(p) {
                let Some(ca) = xml::child(pa, "ControllerAction") else { continue };
                let Some(assign) = xml::child(ca, "AssignControllerAction") else { continue };
                for c in xml::elements(assign) {
                    let k = match c.tag_name().name() {
                        "ObjectController" => {
                            let mut k = None;
                            for x in xml::elements(c) {
                                k = k.or(ctx.controller_element(file, x)?);
                            }
                            k
                        }
                        _ => ctx.controller_element(file, c)?,
                    };
                    found = k.or(found);
                }
            }
        }
    }
    Ok(found)
}

/// The world pose of every entity's reference point, from its Init `TeleportAction` (relative
/// positions after the entity they refer to).
fn place_all(
    ctx: &mut Ctx<'_, '_>,
    file: &str,
    geo: &Geo,
    defs: &[EntityDef],
    init: &[storyboard::InitState<'_, '_>],
    names: &[String],
) -> Result<Vec<Pose>, ImportError> {
    let mut poses: Vec<Option<Pose>> = vec![None; defs.len()];
    for _ in 0..=defs.len() {
        let mut progress = false;
        for i in 0..defs.len() {
            if poses.get(i).is_some_and(Option::is_some) {
                continue;
            }
            let st = init.get(i);
            if let Some(fta) = st.and_then(|s| s.trajectory).filter(|_| st.is_some_and(|s| s.position.is_none())) {
                let p = storyboard::trajectory_start(ctx, file, fta, |ctx, efile, points, offset| {
                    let mut poses = Vec::with_capacity(points.len());
                    for p in points {
                        poses.push(position::resolve(&ctx.params, geo, efile, *p, &|_: &str| None)?);
                    }
                    storyboard::along_polyline(&poses, offset).ok_or_else(|| {
                        ImportError::at(file, fta, format!("initialDistanceOffset = {offset} m is beyond the trajectory's end"))
                    })
                })?;
                if let Some(slot) = poses.get_mut(i) {
                    *slot = Some(p);
                    progress = true;
                }
                continue;
            }
            let Some(pos) = st.and_then(|s| s.position) else { continue };
            let ready = match position::reference(&ctx.params, file, pos)? {
                None => true,
                Some(r) => names.iter().position(|n| *n == r).is_none_or(|j| poses.get(j).is_some_and(Option::is_some)),
            };
            if !ready {
                continue;
            }
            let lookup = |n: &str| names.iter().position(|x| x == n).and_then(|j| poses.get(j).copied().flatten());
            let p = position::resolve(&ctx.params, geo, file, pos, &lookup)?;
            if let Some(slot) = poses.get_mut(i) {
                *slot = Some(p);
                progress = true;
            }
        }
        if !progress {
            break;
        }
    }
    let mut out = Vec::with_capacity(defs.len());
    for (i, d) in defs.iter().enumerate() {
        match poses.get(i).copied().flatten() {
            Some(p) => out.push(p),
            None => {
                let msg = match init.get(i).and_then(|s| s.position) {
                    Some(_) => format!("the position of `{}` refers to entities that wait on each other", d.osc_name),
                    None => format!("`{}` has no TeleportAction and no FollowTrajectoryAction in Init (no initial position)", d.osc_name),
                };
                return Err(ImportError { file: d.file.clone(), line: d.line, element: "ScenarioObject".into(), message: msg });
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::story::{Dimension, Priority, Shape, Transition};
    use crate::trigger::{ConditionKind, DistanceType, Edge, ElementEvent, Rule};

    fn fixtures() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/openscenario")
    }

    fn fixture(name: &str, opts: &ImportOptions) -> Import {
        import(&fixtures().join(name), opts).unwrap_or_else(|e| panic!("{name}: {e}"))
    }

    /// A temporary directory for one test.
    fn tmp(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("flc-osc-import-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("mkdir");
        d
    }

    fn car(name: &str) -> String {
        format!(
            "<ScenarioObject name=\"{name}\"><Vehicle name=\"c\" vehicleCategory=\"car\"><BoundingBox><Center x=\"1.4\" y=\"0\" z=\"0.75\"/>\
             <Dimensions width=\"1.8\" length=\"4.5\" height=\"1.5\"/></BoundingBox>\
             <Performance maxSpeed=\"70\" maxAcceleration=\"5\" maxDeceleration=\"9\"/></Vehicle></ScenarioObject>\n"
        )
    }

    fn place(name: &str, lane: i32, s: f64, v: f64) -> String {
        format!(
            "<Private entityRef=\"{name}\"><PrivateAction><TeleportAction><Position><LanePosition roadId=\"1\" laneId=\"{lane}\" s=\"{s}\" offset=\"0\"/>\
             </Position></TeleportAction></PrivateAction><PrivateAction><LongitudinalAction><SpeedAction>\
             <SpeedActionDynamics dynamicsShape=\"step\" dynamicsDimension=\"time\" value=\"0\"/><SpeedActionTarget>\
             <AbsoluteTargetSpeed value=\"{v}\"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Private>\n"
        )
    }

    /// One story, act, group (`actor`), maneuver and event holding `actions`, started by `trigger`.
    fn story(actor: &str, actions: &str, trigger: &str) -> String {
        format!(
            "<Story name=\"S\"><Act name=\"A\"><ManeuverGroup name=\"G\" maximumExecutionCount=\"1\"><Actors selectTriggeringEntities=\"false\">\
             <EntityRef entityRef=\"{actor}\"/></Actors><Maneuver name=\"M\"><Event name=\"E\" priority=\"override\" maximumExecutionCount=\"1\">\n\
             {actions}\n<StartTrigger>{trigger}</StartTrigger></Event></Maneuver></ManeuverGroup></Act></Story>\n"
        )
    }

    fn at_time(t: f64) -> String {
        format!(
            "<ConditionGroup><Condition name=\"T\" delay=\"0\" conditionEdge=\"none\"><ByValueCondition>\
             <SimulationTimeCondition value=\"{t}\" rule=\"greaterThan\"/></ByValueCondition></Condition></ConditionGroup>"
        )
    }

    fn xosc(params: &str, entities: &str, init: &str, stories: &str) -> String {
        format!(
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<OpenSCENARIO>\n\
             <FileHeader revMajor=\"1\" revMinor=\"2\" date=\"2025-01-01T00:00:00\" author=\"t\" description=\"t\"/>\n\
             <ParameterDeclarations>{params}</ParameterDeclarations>\n<CatalogLocations/>\n<RoadNetwork/>\n\
             <Entities>\n{entities}</Entities>\n<Storyboard>\n<Init><Actions>\n{init}</Actions></Init>\n{stories}\
             <StopTrigger>{}</StopTrigger>\n</Storyboard>\n</OpenSCENARIO>\n",
            at_time(10.0)
        )
    }

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).expect("write");
        p
    }

    /// The 1-based line of the first occurrence of `needle` in `text`.
    fn line_of(text: &str, needle: &str) -> usize {
        text.find(needle).map_or(0, |i| text[..i].matches('\n').count() + 1)
    }

    fn story_of(imp: &Import) -> &Story {
        imp.runs[0].scenario.story.as_ref().expect("story")
    }

    fn find_action<'s>(st: &'s Story, name: &str) -> &'s Action {
        st.acts
            .iter()
            .flat_map(|a| &a.groups)
            .flat_map(|g| &g.maneuvers)
            .flat_map(|m| &m.events)
            .flat_map(|e| &e.actions)
            .find(|a| a.name == name)
            .map(|a| &a.action)
            .unwrap_or_else(|| panic!("no action {name}"))
    }

    fn find_event<'s>(st: &'s Story, name: &str) -> &'s crate::story::Event {
        st.acts
            .iter()
            .flat_map(|a| &a.groups)
            .flat_map(|g| &g.maneuvers)
            .flat_map(|m| &m.events)
            .find(|e| e.name == name)
            .unwrap_or_else(|| panic!("no event {name}"))
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-6
    }

    #[test]
    fn linear_speed_by_rate_and_initial_state() {
        let imp = fixture("speed_linear_rate.xosc", &ImportOptions::default());
        assert_eq!(imp.runs.len(), 1);
        let run = &imp.runs[0];
        let s = &run.scenario;
        assert_eq!(s.name, "speed_linear_rate");
        assert_eq!(s.duration, DEFAULT_MAX_DURATION);
        let st = story_of(&imp);
        match find_action(st, "BrakeAction") {
            Action::Speed { speed: Some(v), of: None, transition, .. } => {
                assert!((v - 0.5556).abs() < 1e-4, "{v}");
                assert_eq!(*transition, Transition { shape: Shape::Linear, dimension: Dimension::Rate, value: 6.0 });
            }
            other => panic!("{other:?}"),
        }
        // Ego 60 m behind the target, both at 50 km/h; positions are box centres (1.4 m ahead
        // of the reference point); the track runs along the ego lane (-2).
        assert!(close(s.follower.start_s.unwrap_or(0.0), 51.4));
        assert!(close(s.follower.initial_speed, 13.888889));
        // An imported ego keeps its lane by default (issue 46), a native scenario pursues.
        assert!(s.follower.lane_keeping && !Scenario::default().follower.lane_keeping);
        assert!(close(s.lead.s.unwrap_or(0.0), 111.4) && close(s.lead.offset, 0.0));
        assert!(close(s.lead.initial_speed, 13.888889));
        assert_eq!(
            (s.lead.vehicle.length, s.lead.vehicle.width, s.lead.vehicle.max_brake, s.lead.vehicle.max_accel),
            (4.5, 1.8, 10.0, 10.0)
        );
        assert_eq!(
            run.entities[1],
            EntityInfo { osc_name: "Target".into(), flc_name: "lead".into(), ref_offset: [1.4, 0.0], length: 4.5, width: 1.8 }
        );
        assert!(matches!(&s.track, TrackSpec::Custom(t) if t.lanes == 3 && t.ego_lane == 1 && t.lane_width == 3.5));
        assert!(matches!(s.stop.trigger.as_ref().and_then(|t| t.conditions().next()).map(|c| &c.kind),
            Some(ConditionKind::SimulationTime { value, rule: Rule::GreaterThan, .. }) if *value == 6.0));
        let ev = find_event(st, "BrakeEvent");
        assert_eq!((ev.priority, ev.max_executions), (Priority::Override, 1));
        assert_eq!(st.acts[0].story, "BrakeStory");
        assert_eq!(s.controller, ControllerKind::Flc);
        assert!(!s.v2v.enabled);
        // One warning line per skipped kind.
        assert_eq!(imp.warnings.iter().filter(|w| w.contains("<Properties>")).count(), 1, "{:?}", imp.warnings);
        assert!(imp.warnings.iter().any(|w| w.contains("<FileHeader>: skipped")));
        // The twin round-trips through TOML.
        let toml = s.to_toml().expect("toml");
        let back = Scenario::from_toml_str(&toml, "twin").expect("twin");
        assert_eq!(back.story, s.story);
    }

    #[test]
    fn parameters_with_overrides() {
        let opts = ImportOptions {
            params: vec![("Decel".into(), "4".into()), ("FinalSpeed".into(), "${1 + 1}".into())],
            ..ImportOptions::default()
        };
        // Overrides are literal values (an expression is not evaluated: an error for a double).
        let e = import(&fixtures().join("speed_linear_rate.xosc"), &opts).expect_err("literal");
        assert!(e.to_string().contains("FinalSpeed"), "{e}");
        let opts =
            ImportOptions { params: vec![("Decel".into(), "4".into()), ("FinalSpeed".into(), "2".into())], ..ImportOptions::default() };
        let imp = fixture("speed_linear_rate.xosc", &opts);
        assert!(matches!(find_action(story_of(&imp), "BrakeAction"),
            Action::Speed { speed: Some(v), transition: Transition { value, .. }, .. } if *v == 2.0 && *value == 4.0));
        assert_eq!(imp.runs[0].params, opts.params);
        let bad = ImportOptions { params: vec![("Nope".into(), "1".into())], ..ImportOptions::default() };
        let e = import(&fixtures().join("speed_linear_rate.xosc"), &bad).expect_err("unknown");
        assert!(e.to_string().contains("Nope"), "{e}");
    }

    #[test]
    fn catalog_vehicles_with_parameter_assignments_and_controller() {
        let imp = fixture("from_catalogs.xosc", &ImportOptions::default());
        let run = &imp.runs[0];
        let s = &run.scenario;
        let info = |n: &str| run.entities.iter().find(|e| e.osc_name == n).cloned().expect("entity");
        let lead = info("CarAhead");
        assert_eq!(lead.flc_name, "lead");
        assert!(close(lead.length, 5.2) && close(lead.ref_offset[0], 1.5), "{lead:?}");
        assert!(close(s.lead.vehicle.max_brake, 8.0));
        let van = info("VanBeside");
        assert!(close(van.length, 6.0) && close(van.ref_offset[0], 1.9), "{van:?}");
        // Ego: the catalog defaults, centre 1.4 m ahead of s = 20.
        assert!(close(s.follower.start_s.unwrap_or(0.0), 21.4));
        assert!(close(s.follower.vehicle.length, 4.5));
        assert!(close(s.lead.s.unwrap_or(0.0), 71.83));
        assert_eq!(s.vehicles.len(), 1);
        assert!(close(s.vehicles[0].s, 41.9) && close(s.vehicles[0].offset.unwrap_or(0.0), 3.5));
        // The ObjectController's catalog entry names flc-robust.
        assert_eq!(s.controller, ControllerKind::FlcRobust);
        // The init activation has no effect: no init event.
        assert!(story_of(&imp).acts.iter().all(|a| a.name != "init"));
        assert!(imp.warnings.iter().any(|w| w.contains("<Init/ActivateControllerAction>")), "{:?}", imp.warnings);
        // --controllers wins; V2V follows the controller.
        let imp = fixture("from_catalogs.xosc", &ImportOptions { controller: Some(ControllerKind::Pipeline), ..ImportOptions::default() });
        assert_eq!(imp.runs[0].scenario.controller, ControllerKind::Pipeline);
        assert!(imp.runs[0].scenario.v2v.enabled);
        let imp = fixture("from_catalogs.xosc", &ImportOptions { ego_mode: EgoMode::Scripted, ..ImportOptions::default() });
        assert_eq!(story_of(&imp).ego, EgoMode::Scripted);
    }

    #[test]
    fn positions_of_every_kind() {
        let imp = fixture("positions.xosc", &ImportOptions::default());
        let s = &imp.runs[0].scenario;
        // The ego at lane -2, s 100: the centreline; offsets from it (+ left) and s of centres.
        assert!(close(s.follower.start_s.unwrap_or(0.0), 101.4));
        let v = |n: &str| s.vehicles.iter().find(|v| v.name == n).cloned().unwrap_or_else(|| panic!("{n}"));
        let expect = [
            ("World", 131.4, 3.5),
            ("Road", 161.4, -3.5),
            ("RelObj", 161.4, 3.5),
            ("RelLane", 181.4, 3.8),
            ("RelLaneDs", 61.4, -3.7),
            ("RelWorld", 211.4, 3.5),
        ];
        for (n, x, off) in expect {
            let veh = v(n);
            assert!(close(veh.s, x) && close(veh.offset.unwrap_or(f64::NAN), off), "{n}: {} {:?}", veh.s, veh.offset);
        }
        // The lead: RelRoad, the nearest vehicle ahead in the ego lane.
        assert!(close(s.lead.s.unwrap_or(0.0), 131.4) && close(s.lead.offset, 0.0));
        assert_eq!(imp.runs[0].entities.iter().find(|e| e.flc_name == "lead").map(|e| e.osc_name.as_str()), Some("RelRoad"));
        // The same on the arc road: through world coordinates (no error, placed on the track).
        let arc = fixture("positions_arc.xosc", &ImportOptions::default());
        assert_eq!(arc.runs[0].scenario.vehicles.len(), 6);
        // --road straight: the straight stand-in road accepts any road id.
        let st = fixture("positions.xosc", &ImportOptions { road: RoadChoice::Straight, ..ImportOptions::default() });
        let s2 = &st.runs[0].scenario;
        assert!(matches!(&s2.track, TrackSpec::Custom(t) if t.lanes == 4 && t.ego_lane == 2));
        assert!(close(s2.follower.start_s.unwrap_or(0.0), 101.4));
        assert!(st.warnings.iter().any(|w| w.contains("<LogicFile>") && w.contains("--road straight")), "{:?}", st.warnings);
    }

    #[test]
    fn conditions_map_to_the_model() {
        let imp = fixture("conditions.xosc", &ImportOptions::default());
        let st = story_of(&imp);
        let only = |e: &str| {
            let t = find_event(st, e).start.as_ref().expect("trigger");
            let g: Vec<Vec<crate::trigger::Condition>> = t.groups().map(|g| g.to_vec()).collect();
            g
        };
        let c = only("EgoBrake");
        assert_eq!(c[0][0].edge, Edge::Rising);
        assert!(matches!(&c[0][0].kind, ConditionKind::TimeHeadway { entity, of, freespace: true, value, rule: Rule::LessThan, .. }
            if entity == "ego" && of == "lead" && *value == 1.0));
        assert!(matches!(
            &only("LeadBrake")[0][0].kind,
            ConditionKind::RelativeDistance { distance: DistanceType::Longitudinal, freespace: true, .. }
        ));
        let ego_stop = only("EgoStop");
        assert_eq!(ego_stop.len(), 1);
        assert_eq!(ego_stop[0].len(), 2);
        assert!(matches!(&ego_stop[0][0].kind, ConditionKind::Ttc { .. }));
        assert!(
            matches!(&ego_stop[0][1].kind, ConditionKind::ElementState { element, state: ElementEvent::RunningState, .. } if element == "LeadStop")
        );
        assert!(matches!(&only("LeadGo")[0][0].kind, ConditionKind::StandStill { duration, .. } if *duration == 1.0));
        let resume = only("EgoResume");
        assert_eq!(resume[0][0].delay, 1.0);
        assert!(matches!(&resume[0][0].kind, ConditionKind::ElementState { state: ElementEvent::EndTransition, .. }));
        assert!(
            matches!(&only("SlowAccel")[0][0].kind, ConditionKind::Acceleration { value, rule: Rule::GreaterThan, .. } if *value == 2.0)
        );
        assert!(
            matches!(&only("SlowOffset")[0][0].kind, ConditionKind::RelativeSpeed { entity, of, .. } if entity == "Side" && of == "Slow")
        );
        assert!(matches!(&only("SideCruise")[0][0].kind, ConditionKind::TraveledDistance { value, .. } if *value == 200.0));
        // Positions: world (350, -1.75) is s 350 on the track (ego lane -2 at y = -5.25),
        // lateral +3.5; shifted by the centre offset (freespace = false, reference point).
        match &only("SideDist")[0][0].kind {
            ConditionKind::Distance { s, lateral, distance: DistanceType::Euclidean, freespace: false, value, .. } => {
                assert!(close(*s, 351.4) && close(*lateral, 3.5) && *value == 10.0, "{s} {lateral}");
            }
            other => panic!("{other:?}"),
        }
        match &only("SlowReach")[0][0].kind {
            ConditionKind::ReachPosition { s, lateral: Some(l), tolerance, .. } => {
                assert!(close(*s, 201.4) && close(*l, -3.5) && *tolerance == 3.0)
            }
            other => panic!("{other:?}"),
        }
        // Variables and parameters.
        assert!(
            matches!(&only("AuxVar")[0][0].kind, ConditionKind::Variable { variable, value: VarValue::Num(v), rule: Rule::EqualTo } if variable == "Phase" && *v == 1.0)
        );
        let aux = only("AuxParam");
        assert!(
            matches!(&aux[0][0].kind, ConditionKind::Variable { variable, value: VarValue::Text(t), .. } if variable == "param:AuxMode" && t == "fast")
        );
        let or = only("AuxOr");
        assert_eq!((or.len(), or[0].len(), or[1].len()), (2, 1, 1));
        assert_eq!(or[0][0].delay, 2.0);
        assert!(
            matches!(find_action(st, "SideAccelAction2"), Action::VariableSet { variable, value: VarValue::Num(v) } if variable == "Phase" && *v == 1.0)
        );
        assert!(matches!(find_action(st, "AuxParamAction2"), Action::VariableModify { add: Some(a), multiply: None, .. } if *a == 1.0));
        assert!(
            matches!(find_action(st, "SlowOffsetAction"), Action::LaneOffset { offset, of: None, shape: Shape::Sinusoidal, max_lateral_acc } if *offset == -0.5 && *max_lateral_acc == 0.3)
        );
        let vars: Vec<(&str, &VarValue)> = st.variables.iter().map(|v| (v.name.as_str(), &v.value)).collect();
        assert_eq!(vars, vec![("Phase", &VarValue::Num(0.0)), ("param:AuxMode", &VarValue::Text("fast".into()))]);
    }

    #[test]
    fn lane_changes_and_priorities() {
        let imp = fixture("lane_change.xosc", &ImportOptions::default());
        let st = story_of(&imp);
        let lc: Vec<&Action> = st
            .acts
            .iter()
            .flat_map(|a| &a.groups)
            .flat_map(|g| &g.maneuvers)
            .flat_map(|m| &m.events)
            .flat_map(|e| &e.actions)
            .map(|a| &a.action)
            .collect();
        // A: lane -1 -> absolute lane -2 (the ego lane: offset 0), sinusoidal over 3 s.
        assert!(lc.iter().any(|a| matches!(a, Action::LaneChange { offset: Some(o), transition: Transition { shape: Shape::Sinusoidal, dimension: Dimension::Time, value }, .. } if *o == 0.0 && *value == 3.0)));
        // B: relative -1 to itself, linear over 60 m; C: +1 with targetLaneOffset 0.5.
        assert!(lc.iter().any(|a| matches!(a, Action::LaneChange { of: Some(_), lanes: Some(-1), transition: Transition { dimension: Dimension::Distance, value, .. }, .. } if *value == 60.0)));
        assert!(lc.iter().any(|a| matches!(a, Action::LaneChange { lanes: Some(1), lane_offset, transition: Transition { shape: Shape::Cubic, .. }, .. } if *lane_offset == 0.5)));
        let pr = fixture("priority.xosc", &ImportOptions::default());
        let st = story_of(&pr);
        assert_eq!(find_event(st, "Skipped").priority, Priority::Skip);
        assert_eq!(find_event(st, "Parallel").priority, Priority::Parallel);
        assert_eq!(find_event(st, "Override").priority, Priority::Override);
        assert!(st.acts.iter().flat_map(|a| &a.groups).flat_map(|g| &g.maneuvers).flat_map(|m| &m.events).any(|e| e.max_executions == 2));
    }

    /// synchronize.xosc with `from` replaced by `to` (once), written into `dir` (its catalog and
    /// road by absolute path); the import's error text, or `None` if it imports.
    fn synchronize_with(dir: &Path, name: &str, from: &str, to: &str) -> Option<String> {
        let text = std::fs::read_to_string(fixtures().join("synchronize.xosc")).expect("fixture");
        assert!(text.contains(from), "{name}: `{from}` is not in the fixture");
        let text = text
            .replacen(from, to, 1)
            .replace("path=\"catalogs\"", &format!("path=\"{}\"", fixtures().join("catalogs").display()))
            .replace("filepath=\"roads/", &format!("filepath=\"{}/", fixtures().join("roads").display()));
        let p = write(dir, name, &text);
        import(&p, &ImportOptions::default()).err().map(|e| e.to_string())
    }

    #[test]
    fn an_element_state_condition_names_the_element_of_its_type() {
        // Euro NCAP CCFhol waits for the maneuver `GVT_Synchronize` of a maneuver group of the same
        // name. synchronize.xosc with its group renamed so: the turn must still start when the
        // maneuver (not the group, which holds the turn too and so never completes first) ends.
        let d = tmp("typed");
        let text = std::fs::read_to_string(fixtures().join("synchronize.xosc"))
            .expect("fixture")
            .replacen("<ManeuverGroup name=\"TargetGroup\"", "<ManeuverGroup name=\"TargetSync\"", 1)
            .replace("path=\"catalogs\"", &format!("path=\"{}\"", fixtures().join("catalogs").display()))
            .replace("filepath=\"roads/", &format!("filepath=\"{}/", fixtures().join("roads").display()));
        assert!(text.contains("<ManeuverGroup name=\"TargetSync\""));
        let imp = import(&write(&d, "typed.xosc", &text), &ImportOptions { ego_mode: EgoMode::Scripted, ..ImportOptions::default() })
            .unwrap_or_else(|e| panic!("{e}"));
        let run = &imp.runs[0];
        let target = run.entities.iter().find(|e| e.osc_name == "Target").map(|e| e.flc_name.clone()).expect("Target");
        let mut sim = crate::Simulation::new(&run.scenario).unwrap_or_else(|e| panic!("{e}"));
        for _ in 0..1200 {
            assert!(sim.step().unwrap_or_else(|e| panic!("{e}")));
        }
        // t = 12 s: the turn (from t = 8 s) has moved Target from y = 1.75 into lane -1.
        let y = sim.scripted_state(&target).map_or(f64::NAN, |st| st.y);
        assert!((y + 1.2467).abs() < 1e-3, "Target at y = {y} (esmini: -1.246668)");
    }

    /// An entity with no TeleportAction starting on its Init trajectory (`follow` mode): the
    /// text of the scenario, with `fta_attrs` on the action and `first` as the first segment.
    fn trajectory_start_xosc(fta_attrs: &str, first: &str) -> String {
        let target = format!(
            "<Private entityRef=\"Target\"><PrivateAction><RoutingAction><FollowTrajectoryAction{fta_attrs}>\
             <TrajectoryRef><Trajectory name=\"T\" closed=\"false\"><Shape><ClothoidSpline>{first}\
             <ClothoidSplineSegment curvatureStart=\"0.02\" curvatureEnd=\"0.02\" length=\"30.0\"/></ClothoidSpline></Shape></Trajectory>\
             </TrajectoryRef><TimeReference><None/></TimeReference><TrajectoryFollowingMode followingMode=\"follow\"/>\
             </FollowTrajectoryAction></RoutingAction></PrivateAction><PrivateAction><LongitudinalAction><SpeedAction>\
             <SpeedActionDynamics dynamicsShape=\"step\" dynamicsDimension=\"time\" value=\"0\"/><SpeedActionTarget>\
             <AbsoluteTargetSpeed value=\"10\"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Private>\n"
        );
        xosc("", &format!("{}{}", car("Ego"), car("Target")), &format!("{}{target}", place("Ego", -1, 10.0, 5.0)), "")
    }

    const START: &str = "<ClothoidSplineSegment curvatureStart=\"0\" curvatureEnd=\"0\" length=\"20.0\"><PositionStart>\
                         <LanePosition roadId=\"1\" laneId=\"-2\" s=\"40.0\" offset=\"0\"/></PositionStart></ClothoidSplineSegment>";

    #[test]
    fn an_entity_without_teleport_starts_at_its_init_trajectory() {
        let d = tmp("trajstart");
        let imp =
            import(&write(&d, "ok.xosc", &trajectory_start_xosc("", START)), &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        let run = &imp.runs[0];
        let target = run.entities.iter().find(|e| e.osc_name == "Target").map(|e| e.flc_name.clone()).expect("Target");
        let mut sim = crate::Simulation::new(&run.scenario).unwrap_or_else(|e| panic!("{e}"));
        let at = |sim: &crate::Simulation| sim.scripted_state(&target).map(|st| (st.x, st.y)).expect("state");
        let (x0, y0) = at(&sim);
        // The bounding box's centre, 1.4 m ahead of the reference point.
        assert!((x0 - 41.4).abs() < 1e-9 && (y0 + 5.25).abs() < 1e-9, "start ({x0}, {y0}): lane -2 at s 40");
        for _ in 0..300 {
            assert!(sim.step().unwrap_or_else(|e| panic!("{e}")));
        }
        // t = 3 s at 10 m/s: 20 m straight, then 10 m of a left arc of radius 50 m.
        let (x, y) = at(&sim);
        let (r, a) = (50.0, 10.0 / 50.0_f64);
        let (xr, yr) = (60.0 + r * a.sin() + 1.4 * a.cos(), -5.25 + r * (1.0 - a.cos()) + 1.4 * a.sin());
        assert!((x - xr).abs() < 0.05 && (y - yr).abs() < 0.05, "t = 3 s: ({x}, {y}), expected ({xr}, {yr})");
    }

    #[test]
    fn a_polyline_start_lies_initial_distance_offset_along_it() {
        use position::Pose;
        let pts = [Pose { x: 100.0, y: 1.75, h: 0.0 }, Pose { x: 0.0, y: 1.75, h: 0.0 }, Pose { x: 0.0, y: 51.75, h: 0.0 }];
        let p = storyboard::along_polyline(&pts, 30.0).expect("on it");
        assert!((p.x - 70.0).abs() < 1e-12 && (p.y - 1.75).abs() < 1e-12 && (p.h - std::f64::consts::PI).abs() < 1e-12, "{p:?}");
        let q = storyboard::along_polyline(&pts, 120.0).expect("on the second segment");
        assert!(q.x.abs() < 1e-12 && (q.y - 21.75).abs() < 1e-12 && (q.h - std::f64::consts::FRAC_PI_2).abs() < 1e-12, "{q:?}");
        assert!(storyboard::along_polyline(&pts, 150.5).is_none(), "past the end");
        assert!(storyboard::along_polyline(&pts[..1], 0.0).is_some() && storyboard::along_polyline(&pts[..1], 1.0).is_none());
        assert!(storyboard::along_polyline(&[], 0.0).is_none());
        // Through the importer: the placement is checked before the action is read.
        let d = tmp("polystart");
        let poly = |offset: &str| {
            trajectory_start_xosc(&format!(" initialDistanceOffset=\"{offset}\""), START).replace(
                &format!("<ClothoidSpline>{START}<ClothoidSplineSegment curvatureStart=\"0.02\" curvatureEnd=\"0.02\" length=\"30.0\"/></ClothoidSpline>"),
                "<Polyline><Vertex><Position><WorldPosition x=\"100\" y=\"1.75\"/></Position></Vertex>\
                 <Vertex><Position><WorldPosition x=\"0\" y=\"1.75\"/></Position></Vertex></Polyline>",
            )
        };
        for (name, offset, needle) in [
            ("beyond.xosc", "100.5", "beyond the trajectory's end"),
            ("neg.xosc", "-1", "initialDistanceOffset"),
            ("nan.xosc", "NaN", "initialDistanceOffset"),
        ] {
            let text = poly(offset);
            assert!(text.contains("<Polyline>"), "the fixture has a polyline");
            let e = import(&write(&d, name, &text), &ImportOptions::default()).err().map(|e| e.to_string()).unwrap_or_default();
            assert!(e.contains(needle) && e.contains(name), "{name}: {e}");
        }
    }

    #[test]
    fn a_trajectory_start_refuses_what_it_cannot_place() {
        let d = tmp("trajstartbad");
        let cases = [
            ("offset.xosc", " initialDistanceOffset=\"5\"", START.to_string(), "initialDistanceOffset other than 0"),
            (
                "nostart.xosc",
                "",
                "<ClothoidSplineSegment curvatureStart=\"0\" curvatureEnd=\"0\" length=\"20.0\"/>".into(),
                "PositionStart",
            ),
            (
                "relative.xosc",
                "",
                START.replace(
                    "<LanePosition roadId=\"1\" laneId=\"-2\" s=\"40.0\" offset=\"0\"/>",
                    "<RelativeObjectPosition entityRef=\"Ego\" dx=\"5\" dy=\"0\"/>",
                ),
                "relative to an entity",
            ),
            ("badlane.xosc", "", START.replace("laneId=\"-2\"", "laneId=\"-9\""), "-9"),
        ];
        for (name, attrs, first, needle) in cases {
            let text = trajectory_start_xosc(attrs, &first);
            let e = import(&write(&d, name, &text), &ImportOptions::default()).err().map(|e| e.to_string());
            let e = e.unwrap_or_else(|| panic!("{name}: imported"));
            assert!(e.contains(needle) && e.contains(name), "{name}: {e}");
        }
        // A second segment's PositionStart stays refused.
        let two = format!("{START}{}", START.replace("s=\"40.0\"", "s=\"60.0\""));
        let e = import(&write(&d, "second.xosc", &trajectory_start_xosc("", &two)), &ImportOptions::default()).err().map(|e| e.to_string());
        assert!(e.as_deref().is_some_and(|e| e.contains("PositionStart")), "{e:?}");
    }

    /// The first `Synchronize` action of `text` (the synchronize fixture, edited): `(master
    /// target, target)`.
    fn sync_targets(dir: &Path, name: &str, text: &str) -> Result<(f64, f64), String> {
        let text = text
            .replace("path=\"catalogs\"", &format!("path=\"{}\"", fixtures().join("catalogs").display()))
            .replace("filepath=\"roads/", &format!("filepath=\"{}/", fixtures().join("roads").display()));
        let imp = import(&write(dir, name, &text), &ImportOptions::default()).map_err(|e| e.to_string())?;
        let st = story_of(&imp);
        let a = st.acts.iter().flat_map(|a| &a.groups).flat_map(|g| &g.maneuvers).flat_map(|m| &m.events).flat_map(|e| &e.actions);
        a.filter_map(|a| match &a.action {
            Action::Synchronize { master_target, target, .. } => Some((*master_target, *target)),
            _ => None,
        })
        .next()
        .ok_or_else(|| "no Synchronize".to_string())
    }

    #[test]
    fn a_trajectory_position_is_a_synchronize_target() {
        let d = tmp("trajpos");
        let text = std::fs::read_to_string(fixtures().join("synchronize.xosc")).expect("fixture");
        let (m0, t0) = sync_targets(&d, "lane.xosc", &text).expect("fixture");
        let master = "<LanePosition roadId=\"1\" laneId=\"-1\" offset=\"0.0\" s=\"250.0\"/>";
        let target = "<LanePosition roadId=\"1\" laneId=\"1\" offset=\"0.0\" s=\"200.0\"/>";
        assert!(text.contains(master) && text.contains(target));
        // The master's target 30 m along a straight spline from s 220; the actor's 50 m along a
        // polyline from s 150 to s 250 of its lane.
        let spline = "<TrajectoryPosition s=\"30\"><TrajectoryRef><Trajectory name=\"M\" closed=\"false\"><Shape><ClothoidSpline>\
                      <ClothoidSplineSegment curvatureStart=\"0\" curvatureEnd=\"0\" length=\"20\"><PositionStart>\
                      <LanePosition roadId=\"1\" laneId=\"-1\" offset=\"0.0\" s=\"220.0\"/></PositionStart></ClothoidSplineSegment>\
                      <ClothoidSplineSegment curvatureStart=\"0\" curvatureEnd=\"0\" length=\"20\"/></ClothoidSpline></Shape>\
                      </Trajectory></TrajectoryRef></TrajectoryPosition>";
        let poly = "<TrajectoryPosition s=\"50\"><TrajectoryRef><Trajectory name=\"T\" closed=\"false\"><Shape><Polyline>\
                    <Vertex><Position><LanePosition roadId=\"1\" laneId=\"1\" offset=\"0.0\" s=\"250.0\"/></Position></Vertex>\
                    <Vertex><Position><LanePosition roadId=\"1\" laneId=\"1\" offset=\"0.0\" s=\"150.0\"/></Position></Vertex>\
                    </Polyline></Shape></Trajectory></TrajectoryRef></TrajectoryPosition>";
        let edited = text.replacen(master, spline, 1).replacen(target, poly, 1);
        let (m1, t1) = sync_targets(&d, "traj.xosc", &edited).unwrap_or_else(|e| panic!("{e}"));
        assert!((m1 - m0).abs() < 1e-9 && (t1 - t0).abs() < 1e-9, "({m1}, {t1}) against ({m0}, {t0})");
        // Bad input, named.
        for (name, from, to, needle) in [
            ("tpneg.xosc", "TrajectoryPosition s=\"50\"", "TrajectoryPosition s=\"-1\"", "s = -1"),
            ("tpnan.xosc", "TrajectoryPosition s=\"50\"", "TrajectoryPosition s=\"NaN\"", "s"),
            ("tpt.xosc", "TrajectoryPosition s=\"50\"", "TrajectoryPosition s=\"50\" t=\"1\"", "t other than 0"),
            ("tpend.xosc", "TrajectoryPosition s=\"30\"", "TrajectoryPosition s=\"40.5\"", "beyond the trajectory's end"),
            ("tppend.xosc", "TrajectoryPosition s=\"50\"", "TrajectoryPosition s=\"100.5\"", "beyond the trajectory's end"),
            ("tpnostart.xosc", "<PositionStart>\n", "<Nope>", "PositionStart"),
        ] {
            let bad = edited.replacen(from, to, 1);
            let bad = if name == "tpnostart.xosc" {
                bad.replacen("<PositionStart><LanePosition roadId=\"1\" laneId=\"-1\" offset=\"0.0\" s=\"220.0\"/></PositionStart>", "", 1)
            } else {
                assert!(bad != edited, "{name}: `{from}` not found");
                bad
            };
            let e = sync_targets(&d, name, &bad).err().unwrap_or_default();
            assert!(e.contains(needle) && e.contains(name), "{name}: {e}");
        }
    }

    #[test]
    fn synchronize_and_trajectory_refuse_bad_input_naming_the_element() {
        let d = tmp("sync");
        assert_eq!(synchronize_with(&d, "ok.xosc", "author=\"flc\"", "author=\"flc\""), None, "the fixture imports");
        let cases = [
            ("master.xosc", "masterEntityRef=\"Ego\">", "masterEntityRef=\"Nobody\">", "Nobody"),
            ("tolnan.xosc", "targetTolerance=\"2.0\"", "targetTolerance=\"NaN\"", "targetTolerance"),
            ("tolneg.xosc", "targetToleranceMaster=\"2.0\"", "targetToleranceMaster=\"-1\"", "tolerance_master"),
            ("speedinf.xosc", "<AbsoluteSpeed value=\"15.0\">", "<AbsoluteSpeed value=\"inf\">", "value"),
            ("steadynan.xosc", "TargetTimeSteadyState time=\"2.0\"", "TargetTimeSteadyState time=\"NaN\"", "time"),
            (
                "notarget.xosc",
                "<TargetPosition>\n                      <LanePosition roadId=\"1\" laneId=\"1\" offset=\"0.0\" s=\"200.0\"/>\n                    </TargetPosition>",
                "",
                "TargetPosition",
            ),
            (
                "relspeed.xosc",
                "<AbsoluteSpeed value=\"15.0\">",
                "<RelativeSpeedToMaster value=\"1\" speedTargetValueType=\"delta\"><X/></RelativeSpeedToMaster><AbsoluteSpeed value=\"15.0\">",
                "FinalSpeed",
            ),
            ("badlane.xosc", "laneId=\"1\" offset=\"0.0\" s=\"200.0\"", "laneId=\"7\" offset=\"0.0\" s=\"200.0\"", "lane 7"),
            ("seglen.xosc", "curvatureEnd=\"0.0\" length=\"50.0\"", "curvatureEnd=\"0.0\" length=\"-50.0\"", "length"),
            ("segnan.xosc", "curvatureStart=\"0.005\"", "curvatureStart=\"NaN\"", "curvatureStart"),
            ("seginf.xosc", "curvatureEnd=\"0.005\"", "curvatureEnd=\"1e999\"", "curvatureEnd"),
            (
                "segstart.xosc",
                "<ClothoidSplineSegment curvatureStart=\"0.005\" curvatureEnd=\"0.005\" length=\"20.0\"/>",
                "<ClothoidSplineSegment curvatureStart=\"0.005\" curvatureEnd=\"0.005\" length=\"20.0\"><PositionStart><WorldPosition x=\"0\" y=\"0\"/></PositionStart></ClothoidSplineSegment>",
                "PositionStart",
            ),
            ("follow.xosc", "followingMode=\"position\"", "followingMode=\"sideways\"", "followingMode"),
            ("timing.xosc", "<None/>", "<Timing domainAbsoluteRelative=\"absolute\" scale=\"1\" offset=\"0\"/>", "TimeReference"),
            ("closed.xosc", "closed=\"false\"", "closed=\"true\"", "closed"),
            (
                "polyline.xosc",
                "<ClothoidSpline>",
                "<Polyline><Vertex><Position><WorldPosition x=\"0\" y=\"0\"/></Position></Vertex></Polyline><ClothoidSpline>",
                "without timing",
            ),
            (
                "noshape.xosc",
                "<ClothoidSplineSegment curvatureStart=\"0.0\" curvatureEnd=\"0.0\" length=\"10.0\"/>",
                "<ClothoidSplineSegment curvatureStart=\"0.0\" curvatureEnd=\"0.0\" length=\"1e6\"/>",
                "length",
            ),
            (
                "catalog.xosc",
                "<Trajectory name=\"TurnLeft\" closed=\"false\">",
                "<CatalogReference catalogName=\"Nope\" entryName=\"x\"/><Trajectory name=\"TurnLeft\" closed=\"false\">",
                "TrajectoryRef",
            ),
            ("elemtype.xosc", "storyboardElementType=\"maneuver\"", "storyboardElementType=\"scene\"", "storyboardElementType"),
        ];
        for (name, from, to, needle) in cases {
            let e = synchronize_with(&d, name, from, to).unwrap_or_else(|| panic!("{name}: imported"));
            assert!(e.contains(name) && e.contains(needle), "{name}: `{e}` should name the file and `{needle}`");
        }
        // A trajectory on a curved road: refused (flc lays it in the road's frame).
        let text = std::fs::read_to_string(fixtures().join("synchronize.xosc"))
            .expect("fixture")
            .replace("laneId=\"1\"", "laneId=\"-1\"")
            .replace("filepath=\"roads/two_way.xodr", &format!("filepath=\"{}", fixtures().join("roads/arc.xodr").display()))
            .replace("path=\"catalogs\"", &format!("path=\"{}\"", fixtures().join("catalogs").display()));
        let e = import(&write(&d, "curved.xosc", &text), &ImportOptions::default()).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("curved.xosc") && e.contains("curved road"), "{e}");
    }

    /// A `RoutingAction/FollowTrajectoryAction` on `T`: a polyline of `vertices`, then `rest`
    /// (TimeReference, following mode) inside the action; `closed` on the trajectory.
    fn trajectory(vertices: &str, rest: &str, closed: &str) -> String {
        format!(
            "<Action name=\"R\"><PrivateAction><RoutingAction><FollowTrajectoryAction><TrajectoryRef>\
             <Trajectory name=\"Tr\" closed=\"{closed}\"><Shape><Polyline>{vertices}</Polyline></Shape></Trajectory></TrajectoryRef>\n\
             {rest}</FollowTrajectoryAction></RoutingAction></PrivateAction></Action>"
        )
    }

    fn vertex(time: &str, x: f64, y: f64) -> String {
        format!("<Vertex time=\"{time}\"><Position><WorldPosition x=\"{x}\" y=\"{y}\" h=\"0.2\"/></Position></Vertex>\n")
    }

    const TIMING: &str = "<TimeReference><Timing domainAbsoluteRelative=\"relative\" scale=\"2\" offset=\"1\"/></TimeReference>\
                          <TrajectoryFollowingMode followingMode=\"position\"/>";

    #[test]
    fn polyline_trajectories_are_read_and_bad_ones_refused() {
        let d = tmp("trajectory");
        let ents = format!("{}{}", car("Ego"), car("T"));
        let init = format!("{}{}", place("Ego", -1, 20.0, 10.0), place("T", -1, 60.0, 0.0));
        let good = format!("{}{}", vertex("0", 60.0, -1.75), vertex("2", 80.0, 0.25));
        let text = xosc("", &ents, &init, &story("T", &trajectory(&good, TIMING, "false"), &at_time(1.0)));
        let imp = import(&write(&d, "good.xosc", &text), &ImportOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        // The stand-in straight road: the track is lane -1's centre (t = -1.75) along +x. The
        // clock reads offset + scale * t (esmini): vertex times (time - 1) / 2.
        match find_action(story_of(&imp), "R") {
            Action::Trajectory { absolute, vertices } => {
                assert!(!absolute);
                let want = [(-0.5, 60.0, 0.0), (0.5, 80.0, 2.0)];
                assert_eq!(vertices.len(), 2);
                for (v, (t, s, off)) in vertices.iter().zip(want) {
                    assert!((v.t - t).abs() < 1e-12 && (v.s - s).abs() < 1e-9 && (v.offset - off).abs() < 1e-9, "{v:?}");
                    assert!((v.heading - 0.2).abs() < 1e-12, "{v:?}");
                }
            }
            other => panic!("{other:?}"),
        }
        let follow = TIMING.replace("\"position\"", "\"follow\"");
        let clothoid = "<Clothoid curvature=\"0\" curvatureDot=\"0\" length=\"10\"/>";
        let relative = "<Vertex time=\"0\"><Position><RelativeObjectPosition entityRef=\"Ego\" dx=\"5\" dy=\"0\"/></Position></Vertex>";
        let none = "<TimeReference><None/></TimeReference><TrajectoryFollowingMode followingMode=\"position\"/>";
        let cases: Vec<(String, &str, &str)> = vec![
            (trajectory(&good, &follow, "false"), "<TrajectoryFollowingMode", "followingMode=\"follow\" is not supported"),
            (
                trajectory(&good, "<TrajectoryFollowingMode followingMode=\"position\"/>", "false"),
                "<FollowTrajectoryAction",
                "<TimeReference> is missing",
            ),
            (trajectory(&good, none, "false"), "<None", "without timing"),
            (trajectory(&good, TIMING, "true"), "<Trajectory ", "closed=\"true\""),
            (trajectory(&good, &TIMING.replace("scale=\"2\"", "scale=\"0\""), "false"), "<Timing", "the scale must be positive"),
            (
                trajectory(&format!("{}{}", vertex("2", 60.0, -1.75), vertex("1", 80.0, 0.0)), TIMING, "false"),
                "<Vertex time=\"1\"",
                "must not decrease",
            ),
            (trajectory(&vertex("NaN", 60.0, -1.75), TIMING, "false"), "<Vertex", "time"),
            (trajectory("", TIMING, "false"), "<Polyline", "at least one vertex"),
            (trajectory(relative, TIMING, "false"), "<RelativeObjectPosition", "relative to an entity"),
            (
                trajectory(&good, TIMING, "false").replace("<Shape><Polyline>", &format!("<Shape>{clothoid}<Polyline>")),
                "<Shape>",
                "exactly one",
            ),
            (trajectory(&good, TIMING, "false").replace(&format!("<Polyline>{good}</Polyline>"), clothoid), "<Clothoid", "unsupported"),
        ];
        for (i, (action, at, msg)) in cases.iter().enumerate() {
            let text = xosc("", &ents, &init, &story("T", action, &at_time(1.0)));
            let p = write(&d, &format!("bad{i}.xosc"), &text);
            let e = import(&p, &ImportOptions::default()).expect_err(msg);
            let want = format!("{}:{}:", p.display(), line_of(&text, at));
            assert!(e.to_string().starts_with(&want) && e.to_string().contains(msg), "case {i}: {e} (want {want} ... {msg})");
        }
        // A MiscObject cannot follow one.
        let misc = "<ScenarioObject name=\"T\"><MiscObject name=\"b\" miscObjectCategory=\"obstacle\" mass=\"10\"><BoundingBox>\
                    <Center x=\"0\" y=\"0\" z=\"0.5\"/><Dimensions width=\"1\" length=\"1\" height=\"1\"/></BoundingBox></MiscObject></ScenarioObject>";
        let init0 = format!("{}{}", place("Ego", -1, 20.0, 10.0), place("T", -1, 60.0, 0.0));
        let text = xosc("", &format!("{}{misc}", car("Ego")), &init0, &story("T", &trajectory(&good, TIMING, "false"), &at_time(1.0)));
        let e = import(&write(&d, "misc.xosc", &text), &ImportOptions::default()).expect_err("misc");
        assert!(e.to_string().contains("MiscObject"), "{e}");
    }

    #[test]
    fn unsupported_elements_name_file_line_and_element() {
        let d = tmp("unsupported");
        let ents = format!("{}{}", car("Ego"), car("T"));
        let init = format!("{}{}", place("Ego", -1, 20.0, 10.0), place("T", -1, 60.0, 10.0));
        let routing = "<Action name=\"R\"><PrivateAction><RoutingAction><AssignRouteAction/></RoutingAction></PrivateAction></Action>";
        let text = xosc("", &ents, &init, &story("T", routing, &at_time(1.0)));
        let p = write(&d, "u.xosc", &text);
        let e = import(&p, &ImportOptions::default()).expect_err("routing");
        // A RoutingAction other than FollowTrajectoryAction: the element named is the action.
        let want = format!("{}:{}: <AssignRouteAction>:", p.display(), line_of(&text, "<AssignRouteAction"));
        assert!(e.to_string().starts_with(&want), "{e} vs {want}");
        assert!(e.to_string().contains("unsupported"), "{e}");
        // A teleport outside Init, an EndOfRoadCondition, a DynamicConstraints: errors too (a
        // continuous distance action is supported: tests/data/openscenario/long_distance_continuous.xosc).
        let cases = [
            (
                "<Action name=\"X\"><PrivateAction><TeleportAction><Position><WorldPosition x=\"1\" y=\"2\"/></Position></TeleportAction></PrivateAction></Action>",
                "TeleportAction",
            ),
            (
                "<Action name=\"X\"><PrivateAction><LongitudinalAction><LongitudinalDistanceAction entityRef=\"Ego\" distance=\"5\" freespace=\"true\" continuous=\"false\"><DynamicConstraints maxSpeed=\"3\"/></LongitudinalDistanceAction></LongitudinalAction></PrivateAction></Action>",
                "DynamicConstraints",
            ),
            ("<Action name=\"X\"><GlobalAction><TrafficAction/></GlobalAction></Action>", "TrafficAction"),
        ];
        for (action, element) in cases {
            let text = xosc("", &ents, &init, &story("T", action, &at_time(1.0)));
            let p = write(&d, "u.xosc", &text);
            let e = import(&p, &ImportOptions::default()).expect_err(element);
            assert!(e.to_string().contains(&format!("<{element}>")), "{element}: {e}");
        }
        let eor = "<ConditionGroup><Condition name=\"C\" delay=\"0\" conditionEdge=\"none\"><ByEntityCondition><TriggeringEntities triggeringEntitiesRule=\"any\">\
                   <EntityRef entityRef=\"T\"/></TriggeringEntities><EntityCondition><EndOfRoadCondition duration=\"1\"/></EntityCondition></ByEntityCondition></Condition></ConditionGroup>";
        let speed = "<Action name=\"X\"><PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape=\"step\" dynamicsDimension=\"time\" value=\"0\"/>\
                     <SpeedActionTarget><AbsoluteTargetSpeed value=\"3\"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Action>";
        let text = xosc("", &ents, &init, &story("T", speed, eor));
        let e = import(&write(&d, "u.xosc", &text), &ImportOptions::default()).expect_err("end of road");
        assert!(e.to_string().contains(&format!(":{}: <EndOfRoadCondition>:", line_of(&text, "<EndOfRoadCondition"))), "{e}");
        // Skipped elements: one warning each, the import goes on.
        let env = "<Action name=\"W\"><GlobalAction><EnvironmentAction/></GlobalAction></Action>";
        let text = xosc("", &ents, &init, &story("T", env, &at_time(1.0)));
        let imp = import(&write(&d, "u.xosc", &text), &ImportOptions::default()).expect("environment");
        assert!(imp.warnings.iter().any(|w| w.contains("<EnvironmentAction>: skipped")), "{:?}", imp.warnings);
        assert!(story_of(&imp).variables.iter().any(|v| v.name == storyboard::SKIPPED_VAR));
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn an_init_distance_by_time_gap_places_its_actor_at_t0() {
        // Lead at 15 m/s to be 2 s ahead of Ego (20 m/s) in Init: the time gap is taken times the
        // referenced entity's speed (esmini's LongDistanceAction), 40 m between centres in the
        // state at t = 0 (esmini applies Init actions before its first logged row), not its
        // teleported s = 200; `distance` likewise. The lead takes the ego's speed.
        let d = tmp("init-gap");
        let ents = format!("{}{}", car("Ego"), car("Lead"));
        for (attr, want) in [("timeGap=\"2.0\"", 40.0), ("distance=\"25.0\"", 25.0)] {
            let keep = format!(
                "<Private entityRef=\"Lead\"><PrivateAction><LongitudinalAction><LongitudinalDistanceAction entityRef=\"Ego\" {attr} \
                 freespace=\"false\" continuous=\"false\" coordinateSystem=\"entity\" displacement=\"leadingReferencedEntity\"/>\
                 </LongitudinalAction></PrivateAction></Private>"
            );
            let init = format!("{}{}{keep}", place("Ego", -1, 50.0, 20.0), place("Lead", -1, 200.0, 15.0));
            let text = xosc("", &ents, &init, "");
            let imp = import(&write(&d, "g.xosc", &text), &ImportOptions { ego_mode: EgoMode::Scripted, ..ImportOptions::default() })
                .unwrap_or_else(|e| panic!("{attr}: {e}"));
            let sim = crate::sim::Simulation::new(&imp.runs[0].scenario).expect("sim");
            let (lead, ego) = (sim.scripted_state("lead").expect("lead"), sim.follower_state(0).expect("ego"));
            assert!(close(lead.x - ego.x, want), "{attr}: centres {} m apart, want {want}", lead.x - ego.x);
            assert!(close(lead.speed, 20.0), "{attr}: lead at {} m/s", lead.speed);
        }
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn the_storyboard_acts_at_t0_and_the_ego_alone_drives_its_speed() {
        let d = tmp("t0");
        let ents = format!("{}{}", car("Ego"), car("Target"));
        let init = format!("{}{}", place("Ego", -1, 20.0, 10.0), place("Target", -1, 60.0, 10.0));
        let jump = "<Action name=\"X\"><PrivateAction><LongitudinalAction><LongitudinalDistanceAction entityRef=\"Ego\" distance=\"30\" freespace=\"false\" \
                    continuous=\"false\" displacement=\"leadingReferencedEntity\" coordinateSystem=\"entity\"/></LongitudinalAction></PrivateAction></Action>";
        let opts = ImportOptions { ego_mode: EgoMode::Scripted, dynamics: crate::story::Dynamics::Kinematic, ..ImportOptions::default() };
        // An event whose trigger is true at t = 0: its placement (30 m ahead of the ego, not the
        // 40 m of Init) is in the state at t = 0
        // (esmini's first logged row), before any step.
        let text = xosc("", &ents, &init, &story("Target", jump, &at_time(0.0).replace("greaterThan", "greaterOrEqual")));
        let imp = import(&write(&d, "t0.xosc", &text), &opts).expect("t0");
        let sim = crate::sim::Simulation::new(&imp.runs[0].scenario).expect("sim");
        assert_eq!(sim.time(), 0.0);
        let x0 = sim.scripted_state("lead").map(|st| st.x).unwrap_or(f64::NAN);
        assert!((x0 - 51.4).abs() < 1e-6, "{x0}");
        // The ego alone: it runs, nothing is in front, it keeps its speed.
        let text = xosc("", &car("Ego"), &place("Ego", -1, 20.0, 10.0), "");
        let imp = import(&write(&d, "alone.xosc", &text), &opts).expect("alone");
        // A negative speed (esmini 3.6.0 plays it so): the target drives backwards along its lane,
        // still facing forward, 2.5 m/s x 2 s = 5 m.
        let back = xosc("", &ents, &format!("{}{}", place("Ego", -1, 20.0, 10.0), place("Target", -1, 60.0, -2.5)), "");
        let imp_back = import(&write(&d, "back.xosc", &back), &opts).expect("backwards");
        let mut sim = crate::sim::Simulation::new(&imp_back.runs[0].scenario).expect("sim");
        let start = sim.scripted_state("lead").map(|st| st.x).unwrap_or(f64::NAN);
        while sim.time() < 2.0 - 1e-9 {
            sim.step().expect("step");
        }
        let st = *sim.scripted_state("lead").expect("target");
        assert!((start - st.x - 5.0).abs() < 1e-6 && st.speed == -2.5 && st.yaw.abs() < 1e-12, "{start} -> {st:?}");
        // A relative target speed below zero (ALKS 4.3_1's varying speed at a slow ego): from
        // t = 1 s the target runs 2 m/s backwards, the ego's 10 m/s less 12.
        let slower = "<Action name=\"X\"><PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape=\"step\" \
                      dynamicsDimension=\"time\" value=\"0\"/><SpeedActionTarget><RelativeTargetSpeed entityRef=\"Ego\" value=\"-12\" \
                      speedTargetValueType=\"delta\" continuous=\"false\"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Action>";
        let text = xosc("", &ents, &init, &story("Target", slower, &at_time(1.0)));
        let imp_slower = import(&write(&d, "slower.xosc", &text), &opts).expect("slower");
        let mut sim = crate::sim::Simulation::new(&imp_slower.runs[0].scenario).expect("sim");
        let mut xs = Vec::new();
        while sim.time() < 3.0 - 1e-9 {
            sim.step().expect("step");
            xs.push((sim.time(), sim.scripted_state("lead").map(|st| (st.x, st.speed)).unwrap_or((f64::NAN, f64::NAN))));
        }
        let (_, (x_end, v_end)) = xs[xs.len() - 1];
        let (_, (x_2, _)) = xs[xs.len() - 101];
        assert!(v_end == -2.0 && (x_2 - x_end - 2.0).abs() < 1e-6, "{:?}", &xs[xs.len() - 3..]);
        let mut s = imp.runs[0].scenario.clone();
        s.duration = 5.0;
        let r = crate::runner::run(&s).expect("run");
        let sr = &r.series;
        let (first, last) = (sr.get(0).expect("rows"), sr.get(sr.len() - 1).expect("rows"));
        assert!((last.follower_speed - 10.0).abs() < 1e-9 && (last.follower_x - first.follower_x - 49.9).abs() < 0.01, "{last:?}");
        assert!((0..sr.len()).filter_map(|i| sr.get(i)).all(|row| row.gap.is_nan() && row.lead_gap.is_nan() && row.lead_speed.is_nan()));
        assert!(r.collision.is_none() && r.contacts.is_empty());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn misc_objects_stand_and_cannot_move() {
        let d = tmp("misc");
        let obj = "<ScenarioObject name=\"Box\"><MiscObject miscObjectCategory=\"obstacle\" mass=\"50\" name=\"b\"><BoundingBox><Center x=\"0\" y=\"0\" z=\"0.5\"/>\
                   <Dimensions width=\"1\" length=\"2\" height=\"1\"/></BoundingBox></MiscObject></ScenarioObject>\n";
        let ents = format!("{}{obj}", car("Ego"));
        let box_at = "<Private entityRef=\"Box\"><PrivateAction><TeleportAction><Position><LanePosition roadId=\"1\" laneId=\"-1\" s=\"80\"/></Position></TeleportAction></PrivateAction></Private>";
        let init = format!("{}{box_at}", place("Ego", -1, 20.0, 10.0));
        let speed = "<Action name=\"X\"><PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape=\"step\" dynamicsDimension=\"time\" value=\"0\"/>\
                     <SpeedActionTarget><AbsoluteTargetSpeed value=\"3\"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Action>";
        let text = xosc("", &ents, &init, &story("Ego", speed, &at_time(1.0)));
        let imp = import(&write(&d, "m.xosc", &text), &ImportOptions::default()).expect("misc");
        let s = &imp.runs[0].scenario;
        // The only other entity is the lead, standing.
        assert_eq!((s.lead.vehicle.length, s.lead.vehicle.width, s.lead.initial_speed), (2.0, 1.0, 0.0));
        assert!(close(s.lead.s.unwrap_or(0.0), 80.0));
        let text = xosc("", &ents, &init, &story("Box", speed, &at_time(1.0)));
        let e = import(&write(&d, "m.xosc", &text), &ImportOptions::default()).expect_err("moving box");
        assert!(e.to_string().contains("MiscObject"), "{e}");
        // Only the ego: no lead.
        let text = xosc("", &car("Ego"), &place("Ego", -1, 20.0, 10.0), "");
        let imp = import(&write(&d, "m.xosc", &text), &ImportOptions::default()).expect("the ego alone runs");
        let s = &imp.runs[0].scenario;
        assert!(s.lead.absent && !s.v2v.enabled && s.vehicles.is_empty());
        assert!(!imp.runs[0].entities.iter().any(|e| e.flc_name == "lead"));
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn triggering_entities_any_and_all() {
        let d = tmp("any");
        let ents = format!("{}{}{}", car("Ego"), car("A"), car("B"));
        let init = format!("{}{}{}", place("Ego", -1, 20.0, 10.0), place("A", -1, 60.0, 10.0), place("B", -2, 60.0, 10.0));
        let cond = |rule: &str| {
            format!(
                "<ConditionGroup><Condition name=\"C\" delay=\"0.5\" conditionEdge=\"rising\"><ByEntityCondition><TriggeringEntities triggeringEntitiesRule=\"{rule}\">\
                 <EntityRef entityRef=\"A\"/><EntityRef entityRef=\"B\"/></TriggeringEntities><EntityCondition><SpeedCondition value=\"5\" rule=\"lessThan\"/>\
                 </EntityCondition></ByEntityCondition></Condition>\
                 <Condition name=\"T\" delay=\"0\" conditionEdge=\"none\"><ByValueCondition><SimulationTimeCondition value=\"1\" rule=\"greaterOrEqual\"/></ByValueCondition></Condition></ConditionGroup>"
            )
        };
        let speed = "<Action name=\"X\"><PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape=\"cubic\" dynamicsDimension=\"distance\" value=\"30\"/>\
                     <SpeedActionTarget><RelativeTargetSpeed entityRef=\"A\" value=\"1.5\" speedTargetValueType=\"factor\" continuous=\"true\"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Action>";
        for (rule, shape) in [("any", (2, 2)), ("all", (1, 3))] {
            let text = xosc("", &ents, &init, &story("Ego", speed, &cond(rule)));
            let imp = import(&write(&d, "a.xosc", &text), &ImportOptions::default()).expect(rule);
            let st = story_of(&imp);
            let t = find_event(st, "E").start.as_ref().expect("trigger");
            let groups: Vec<usize> = t.groups().map(|g| g.len()).collect();
            assert_eq!((groups.len(), groups[0]), shape, "{rule}: {groups:?}");
            let first = t.conditions().next().expect("condition");
            assert_eq!((first.delay, first.edge), (0.5, Edge::Rising));
            assert!(
                matches!(find_action(st, "X"), Action::Speed { of: Some(o), factor: Some(f), continuous: true, transition: Transition { shape: Shape::Cubic, dimension: Dimension::Distance, .. }, .. } if o == "lead" && *f == 1.5)
            );
        }
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn catalog_cycles_and_depth_are_errors() {
        let files = CatalogFiles::empty();
        let cats = Catalogs::new(&files);
        let mut ctx = Ctx { params: Params::new(), cats: &cats, warn: Warnings::default(), stack: Vec::new(), performance: None };
        let doc = xml::parse("<CatalogReference catalogName=\"c\" entryName=\"e\"/>", "f.xosc").expect("xml");
        let n = doc.root_element();
        ctx.enter_catalog("f.xosc", n, "c", "a").expect("a");
        ctx.enter_catalog("f.xosc", n, "c", "b").expect("b");
        let e = ctx.enter_catalog("f.xosc", n, "c", "a").expect_err("cycle");
        assert!(e.to_string().contains("cycle: c/a -> c/b -> c/a"), "{e}");
        ctx.leave_catalog();
        ctx.leave_catalog();
        for i in 0..catalog::MAX_DEPTH {
            ctx.enter_catalog("f.xosc", n, "c", &format!("e{i}")).expect("depth");
        }
        let e = ctx.enter_catalog("f.xosc", n, "c", "deep").expect_err("depth");
        assert!(e.to_string().contains("deeper than 8"), "{e}");
        // A catalog entry that refers to itself: rejected, no recursion.
        let d = tmp("cycle");
        std::fs::create_dir_all(d.join("cat")).expect("mkdir");
        write(
            &d.join("cat"),
            "v.xosc",
            "<OpenSCENARIO><Catalog name=\"V\"><Vehicle name=\"self\"><BoundingBox><Center x=\"1\" y=\"0\" z=\"0\"/><Dimensions width=\"2\" length=\"4\" height=\"1\"/></BoundingBox>\
             <CatalogReference catalogName=\"V\" entryName=\"self\"/></Vehicle></Catalog></OpenSCENARIO>",
        );
        let ents =
            format!("{}<ScenarioObject name=\"T\"><CatalogReference catalogName=\"V\" entryName=\"self\"/></ScenarioObject>\n", car("Ego"));
        let init = format!("{}{}", place("Ego", -1, 20.0, 10.0), place("T", -1, 60.0, 10.0));
        let text = xosc("", &ents, &init, "").replace(
            "<CatalogLocations/>",
            "<CatalogLocations><VehicleCatalog><Directory path=\"cat\"/></VehicleCatalog></CatalogLocations>",
        );
        let e = import(&write(&d, "c.xosc", &text), &ImportOptions::default()).expect_err("self reference");
        assert!(e.to_string().contains("v.xosc:1: <CatalogReference>: unsupported"), "{e}");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn too_many_entities_are_rejected_before_anything_is_built() {
        let d = tmp("many");
        // 257 entities that could not even be read (no Vehicle): the count is checked first.
        let ents: String = (0..=entities::MAX_ENTITIES).map(|i| format!("<ScenarioObject name=\"e{i}\"/>\n")).collect();
        let text = xosc("", &ents, "", "");
        let e = import(&write(&d, "n.xosc", &text), &ImportOptions::default()).expect_err("limit");
        assert!(e.to_string().contains("257 entities, more than the limit of 256"), "{e}");
        assert!(e.to_string().contains("<Entities>"), "{e}");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn init_speed_with_a_shape_becomes_an_init_event_and_names_are_reserved() {
        let d = tmp("init");
        let ents = format!("{}{}{}", car("Ego"), car("lead"), car("follower1"));
        let slow = "<Private entityRef=\"lead\"><PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape=\"linear\" dynamicsDimension=\"rate\" value=\"2\"/>\
                    <SpeedActionTarget><AbsoluteTargetSpeed value=\"4\"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Private>";
        let init = format!("{}{}{}{slow}", place("Ego", -1, 20.0, 10.0), place("lead", -2, 60.0, 10.0), place("follower1", -1, 40.0, 10.0));
        let text = xosc("", &ents, &init, "");
        let imp = import(&write(&d, "i.xosc", &text), &ImportOptions::default()).expect("init");
        let run = &imp.runs[0];
        let names: Vec<(&str, &str)> = run.entities.iter().map(|e| (e.osc_name.as_str(), e.flc_name.as_str())).collect();
        // follower1 is ahead in the ego lane: the lead; the OSC `lead` is renamed.
        assert_eq!(names, vec![("Ego", "ego"), ("lead", "lead_osc"), ("follower1", "lead")]);
        let st = story_of(&imp);
        assert_eq!(st.acts[0].name, "init");
        assert_eq!(st.acts[0].groups[0].actors, vec!["lead_osc".to_string()]);
        assert!(
            matches!(find_action(st, "init/lead_osc/0"), Action::Speed { speed: Some(v), transition: Transition { shape: Shape::Linear, .. }, .. } if *v == 4.0)
        );
        assert!(close(run.scenario.vehicles[0].initial_speed, 10.0));
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn parameter_actions_variables_in_init_and_errors() {
        let d = tmp("params");
        let ents = format!("{}{}", car("Ego"), car("T"));
        let init = format!(
            "{}{}<GlobalAction><ParameterAction parameterRef=\"Mode\"><ModifyAction><Rule><MultiplyByValue value=\"3\"/></Rule></ModifyAction></ParameterAction></GlobalAction>",
            place("Ego", -1, 20.0, 10.0),
            place("T", -1, 60.0, 10.0)
        );
        let set = "<Action name=\"P\"><GlobalAction><ParameterAction parameterRef=\"Mode\"><SetAction value=\"7\"/></ParameterAction></GlobalAction></Action>";
        let cond = "<ConditionGroup><Condition name=\"C\" delay=\"0\" conditionEdge=\"none\"><ByValueCondition>\
                    <ParameterCondition parameterRef=\"Mode\" value=\"6\" rule=\"greaterOrEqual\"/></ByValueCondition></Condition></ConditionGroup>";
        let params = "<ParameterDeclaration name=\"Mode\" parameterType=\"integer\" value=\"2\"/>";
        let text = xosc(params, &ents, &init, &story("T", set, cond));
        let imp = import(&write(&d, "p.xosc", &text), &ImportOptions::default()).expect("parameter actions");
        let st = story_of(&imp);
        // Init multiplies the initial value (2 * 3); the story sets it.
        assert_eq!(st.variables, vec![Variable { name: "param:Mode".into(), value: VarValue::Num(6.0) }]);
        assert!(
            matches!(find_action(st, "P"), Action::VariableSet { variable, value: VarValue::Num(v) } if variable == "param:Mode" && *v == 7.0)
        );
        let t = find_event(st, "E").start.as_ref().expect("trigger");
        assert!(matches!(&t.conditions().next().expect("c").kind, ConditionKind::Variable { rule: Rule::GreaterOrEqual, .. }));
        // Errors: a TTC to a position, a trajectory coordinate system, a
        // position on another road, a relative position in a condition.
        let lc = "<Action name=\"X\"><PrivateAction><LateralAction><LaneChangeAction><LaneChangeActionDynamics dynamicsShape=\"linear\" dynamicsDimension=\"rate\" value=\"1\"/>\
                  <LaneChangeTarget><AbsoluteTargetLane value=\"-2\"/></LaneChangeTarget></LaneChangeAction></LateralAction></PrivateAction></Action>";
        let text =
            xosc("", &ents, &format!("{}{}", place("Ego", -1, 20.0, 10.0), place("T", -1, 60.0, 10.0)), &story("T", lc, &at_time(1.0)));
        // A lane change by rate (esmini: the peak lateral speed) imports as such.
        let imp = import(&write(&d, "p.xosc", &text), &ImportOptions::default()).expect("rate");
        assert!(matches!(find_action(story_of(&imp), "X"), Action::LaneChange { transition, .. }
            if transition.dimension == crate::story::Dimension::Rate && transition.value == 1.0));
        let speed = "<Action name=\"X\"><PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape=\"step\" dynamicsDimension=\"time\" value=\"0\"/>\
                     <SpeedActionTarget><AbsoluteTargetSpeed value=\"3\"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Action>";
        let by_entity = |inner: &str| {
            format!(
                "<ConditionGroup><Condition name=\"C\" delay=\"0\" conditionEdge=\"none\"><ByEntityCondition><TriggeringEntities triggeringEntitiesRule=\"any\">\
                 <EntityRef entityRef=\"Ego\"/></TriggeringEntities><EntityCondition>{inner}</EntityCondition></ByEntityCondition></Condition></ConditionGroup>"
            )
        };
        let cases = [
            (
                "<TimeToCollisionCondition value=\"3\" freespace=\"true\" rule=\"lessThan\"><TimeToCollisionConditionTarget><Position><WorldPosition x=\"1\" y=\"1\"/></Position></TimeToCollisionConditionTarget></TimeToCollisionCondition>",
                "<Position>: unsupported",
            ),
            (
                "<RelativeDistanceCondition entityRef=\"T\" value=\"3\" freespace=\"true\" rule=\"lessThan\" relativeDistanceType=\"longitudinal\" coordinateSystem=\"trajectory\"/>",
                "coordinateSystem=\"trajectory\"",
            ),
            (
                "<ReachPositionCondition tolerance=\"1\"><Position><RelativeRoadPosition entityRef=\"T\" ds=\"1\" dt=\"0\"/></Position></ReachPositionCondition>",
                "<RelativeRoadPosition>: a position relative",
            ),
            ("<SpeedCondition value=\"3\" rule=\"lessThan\" direction=\"lateral\"/>", "direction=\"lateral\""),
        ];
        for (inner, want) in cases {
            let text = xosc(
                "",
                &ents,
                &format!("{}{}", place("Ego", -1, 20.0, 10.0), place("T", -1, 60.0, 10.0)),
                &story("T", speed, &by_entity(inner)),
            );
            let e = import(&write(&d, "p.xosc", &text), &ImportOptions::default()).expect_err(want);
            assert!(e.to_string().contains(want), "{want}: {e}");
        }
        // Positions on another road than the ego's (with a road file).
        let road = "<OpenDRIVE><header revMajor=\"1\" revMinor=\"6\"/><road id=\"1\" length=\"500\" junction=\"-1\"><planView><geometry s=\"0\" x=\"0\" y=\"0\" hdg=\"0\" length=\"500\"><line/></geometry></planView>\
                    <lanes><laneSection s=\"0\"><center><lane id=\"0\" type=\"none\"/></center><right><lane id=\"-1\" type=\"driving\"><width sOffset=\"0\" a=\"3.5\" b=\"0\" c=\"0\" d=\"0\"/></lane></right></laneSection></lanes></road></OpenDRIVE>";
        write(&d, "r.xodr", road);
        let t_on_2 = place("T", -1, 60.0, 10.0).replace("roadId=\"1\"", "roadId=\"2\"");
        let text = xosc("", &ents, &format!("{}{t_on_2}", place("Ego", -1, 20.0, 10.0)), "")
            .replace("<RoadNetwork/>", "<RoadNetwork><LogicFile filepath=\"r.xodr\"/></RoadNetwork>");
        let e = import(&write(&d, "p.xosc", &text), &ImportOptions::default()).expect_err("road 2");
        assert!(e.to_string().contains("only one road"), "{e}");
        // The same file with --road straight: any road id is the straight road.
        assert!(import(&write(&d, "p.xosc", &text), &ImportOptions { road: RoadChoice::Straight, ..ImportOptions::default() }).is_ok());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn distribution_runs() {
        let d = tmp("dist");
        let ents = format!("{}{}", car("Ego"), car("T"));
        let init = format!("{}{}", place("Ego", -1, 20.0, 10.0), place("T", -1, 60.0, 10.0));
        let speed = "<Action name=\"X\"><PrivateAction><LongitudinalAction><SpeedAction><SpeedActionDynamics dynamicsShape=\"linear\" dynamicsDimension=\"rate\" value=\"$D\"/>\
                     <SpeedActionTarget><AbsoluteTargetSpeed value=\"$V\"/></SpeedActionTarget></SpeedAction></LongitudinalAction></PrivateAction></Action>";
        let params = "<ParameterDeclaration name=\"V\" parameterType=\"double\" value=\"5\"/><ParameterDeclaration name=\"D\" parameterType=\"double\" value=\"2\"/>";
        write(&d, "base.xosc", &xosc(params, &ents, &init, &story("T", speed, &at_time(1.0))));
        let dist = "<OpenSCENARIO><FileHeader revMajor=\"1\" revMinor=\"2\" date=\"2025-01-01T00:00:00\" author=\"t\" description=\"t\"/>\
                    <ParameterValueDistribution><ScenarioFile filepath=\"base.xosc\"/><Deterministic>\
                    <DeterministicSingleParameterDistribution parameterName=\"V\"><DistributionSet><Element value=\"3\"/><Element value=\"6\"/></DistributionSet></DeterministicSingleParameterDistribution>\
                    <DeterministicSingleParameterDistribution parameterName=\"D\"><DistributionSet><Element value=\"1\"/><Element value=\"4\"/></DistributionSet></DeterministicSingleParameterDistribution>\
                    </Deterministic></ParameterValueDistribution></OpenSCENARIO>";
        let imp = import(&write(&d, "dist.xosc", dist), &ImportOptions::default()).expect("distribution");
        assert_eq!(imp.runs.len(), 4);
        for (i, run) in imp.runs.iter().enumerate() {
            assert_eq!(run.scenario.name, "base");
            assert!(run.scenario.variant.as_deref().is_some_and(|v| v.starts_with(&format!("p{i} V="))), "{:?}", run.scenario.variant);
            let v: f64 = run.params.iter().find(|(n, _)| n == "V").map_or(f64::NAN, |(_, v)| v.parse().unwrap_or(f64::NAN));
            let dd: f64 = run.params.iter().find(|(n, _)| n == "D").map_or(f64::NAN, |(_, v)| v.parse().unwrap_or(f64::NAN));
            let st = run.scenario.story.as_ref().expect("story");
            assert!(
                matches!(find_action(st, "X"), Action::Speed { speed: Some(s), transition: Transition { value, .. }, .. } if *s == v && *value == dd),
                "{i}"
            );
        }
        let combos: Vec<(String, String)> = imp.runs.iter().map(|r| (r.params[0].1.clone(), r.params[1].1.clone())).collect();
        assert_eq!(combos.len(), 4);
        let _ = std::fs::remove_dir_all(&d);
    }
}
