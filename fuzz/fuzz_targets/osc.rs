//! The OpenSCENARIO importer's input layer on arbitrary bytes (as UTF-8, lossily): the safe XML
//! reader (`openscenario::xml::parse`), the `${}` expression evaluator (inputs up to 4 KiB, with
//! a fixed set of parameters) and `Params::declare` on a small document whose parameter value is
//! the input, for every parameter type, followed by the typed attribute getters on it; the
//! OpenDRIVE reader (`openscenario::road::from_str`) and, on a network it accepts, the route of
//! lane -1 from each of its first roads through links and junctions (`junction::route`, `join`);
//! and the whole importer (storyboard, positions, trajectories, pedestrians) on an input that is
//! an `OpenSCENARIO` scenario, on the stand-in straight road, in both ego modes. Nothing may
//! panic; an accepted value must satisfy its type, an imported scenario must validate; a route
//! names roads of the file once each, in increasing positions, and its joined road is as long as
//! its roads.
#![no_main]

use std::collections::BTreeMap;

use flc_sim::openscenario::expr::{self, Value};
use flc_sim::openscenario::params::{ParamType, Params};
use flc_sim::openscenario::{self, ImportOptions, RoadChoice, distribution, junction, road, xml};
use flc_sim::story::EgoMode;
use libfuzzer_sys::fuzz_target;

const TYPES: [&str; 7] = ["double", "integer", "unsignedInt", "unsignedShort", "boolean", "string", "dateTime"];

fn lookup(name: &str) -> Option<Value> {
    match name {
        "a" => Some(Value::Num(3.0)),
        "z" => Some(Value::Num(0.0)),
        "big" => Some(Value::Num(1e308)),
        "t" => Some(Value::Bool(true)),
        "s" => Some(Value::Str("text".into())),
        _ => None,
    }
}

/// `s` as XML attribute text.
fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            c => out.push(c),
        }
    }
    out
}

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);

    // 1. The XML reader, and the distribution reader on anything it accepts; a scenario goes
    //    through the whole importer (4.).
    let mut scenario = false;
    if let Ok(doc) = xml::parse(&text, "fuzz.xosc") {
        if distribution::is_distribution(&doc) {
            if let Ok(d) = distribution::read(&doc, std::path::Path::new("fuzz.xosc")) {
                assert!(d.len() as u64 <= distribution::MAX_RUNS);
            }
        } else {
            scenario = doc.root_element().has_tag_name("OpenSCENARIO") && xml::child(doc.root_element(), "Storyboard").is_some();
        }
    }
    if scenario {
        let dir = std::env::temp_dir().join(format!("flc-fuzz-osc-{}", std::process::id()));
        if std::fs::create_dir_all(&dir).is_ok() && std::fs::write(dir.join("fuzz.xosc"), text.as_bytes()).is_ok() {
            for ego_mode in [EgoMode::Controller, EgoMode::Scripted] {
                let opts = ImportOptions { road: RoadChoice::Straight, ego_mode, ..ImportOptions::default() };
                if let Ok(imp) = openscenario::import(&dir.join("fuzz.xosc"), &opts) {
                    for run in &imp.runs {
                        assert!(run.scenario.validate().is_ok(), "an imported scenario must validate");
                    }
                }
            }
        }
    }

    // 1b. The OpenDRIVE reader and the junction route on anything it accepts.
    if let Ok(net) = road::from_str(&text, "fuzz.xodr") {
        for r in net.roads.iter().take(8) {
            let Ok(route) = junction::route(&net, r, -1) else { continue };
            assert!(route.roads.len() <= junction::MAX_ROUTE_ROADS && route.roads.len() == route.starts.len());
            assert!(route.roads.iter().all(|id| net.road(id).is_some()), "a route names roads of the file");
            let mut ids: Vec<&String> = route.roads.iter().collect();
            ids.sort();
            ids.dedup();
            assert_eq!(ids.len(), route.roads.len(), "each road once");
            assert!(route.starts.windows(2).all(|w| w[0] < w[1]), "{:?}", route.starts);
            if let Ok(joined) = junction::join(&net, &route, -1) {
                let total: f64 = route.roads.iter().filter_map(|id| net.road(id)).map(|r| r.length).sum();
                assert!((joined.length - total).abs() <= 1e-6 * total.max(1.0));
                let _ = joined.world(0.5 * joined.length, -1.0);
            }
        }
    }

    // 2. The expression evaluator.
    if text.len() <= expr::MAX_LEN {
        if let Ok(Value::Num(x)) = expr::eval(&text, &lookup) {
            assert!(x.is_finite(), "{text:?} gave {x}");
        }
    }

    // 3. A declaration whose value is the input, for each type, then the getters on it.
    let value = escape(&text);
    for ty in TYPES {
        let doc_text = format!(
            "<R><ParameterDeclarations>\
             <ParameterDeclaration name=\"a\" parameterType=\"double\" value=\"3\"/>\
             <ParameterDeclaration name=\"p\" parameterType=\"{ty}\" value=\"{value}\">\
             <ConstraintGroup><ValueConstraint rule=\"notEqualTo\" value=\"{value}\"/></ConstraintGroup>\
             <ConstraintGroup><ValueConstraint rule=\"equalTo\" value=\"{value}\"/></ConstraintGroup>\
             </ParameterDeclaration></ParameterDeclarations>\
             <A x=\"{value}\" y=\"$p\"/></R>"
        );
        let Ok(doc) = xml::parse(&doc_text, "fuzz.xosc") else { continue };
        let root = doc.root_element();
        let mut params = Params::new();
        let declared = params.declare_in(root, "fuzz.xosc", &BTreeMap::new());
        if declared.is_ok() {
            let p = params.get("p").expect("declared");
            let kind = ParamType::parse(ty).expect("type");
            assert_eq!(p.ty, kind);
            assert_eq!(kind.convert(p.value.clone()).as_ref(), Ok(&p.value), "conversion is idempotent");
        }
        let Some(a) = xml::child(root, "A") else { continue };
        for attr in ["x", "y"] {
            let _ = params.str_attr(a, attr, "fuzz.xosc");
            if let Ok(Some(x)) = params.num_attr(a, attr, "fuzz.xosc") {
                assert!(x.is_finite());
            }
            let _ = params.int_attr(a, attr, "fuzz.xosc");
            let _ = params.bool_attr(a, attr, "fuzz.xosc");
            let _ = params.enum_attr(a, attr, "fuzz.xosc", &["linear", "step"]);
        }
        // The input as an override of a declared parameter.
        let mut fresh = Params::new();
        let over: BTreeMap<String, String> = [("a".to_string(), text.to_string())].into();
        let _ = fresh.declare_in(root, "fuzz.xosc", &over);
    }
});
