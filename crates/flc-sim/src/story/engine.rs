//! The storyboard's runtime: element states, triggers and variables ([`StoryState`]).

use std::collections::HashMap;

use super::{Action, Priority, Story};
use crate::trigger::{ElementEvent, ElementKind, ElementStatus, EntityState, PhaseStatus, TriggerState, VarValue, WorldView};

/// An action the story started this step: run it on every actor of its maneuver group.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Started {
    /// Index of the action (document order over the whole story).
    pub action: usize,
}

/// One logged transition of an event or action ([`StoryState::transitions`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transition {
    /// Simulation time at the start of the step it happened in, s.
    pub t: f64,
    /// `true`: an event; `false`: an action.
    pub event: bool,
    /// Index of the event / action (document order).
    pub index: usize,
    /// What happened.
    pub what: ElementEvent,
}

/// Most transitions kept in the log (a hostile story re-running events forever cannot grow it
/// without bound).
const MAX_LOG: usize = 100_000;

/// Where an action sits: `(act, group, maneuver, event, action)` indices.
type Path = (usize, usize, usize, usize, usize);

/// The states and variables the story's own conditions read (kept apart from the trigger
/// states, so that the triggers can be updated while reading them).
#[derive(Debug, Clone)]
struct Elements {
    acts: Vec<ElementStatus>,
    groups: Vec<ElementStatus>,
    maneuvers: Vec<ElementStatus>,
    events: Vec<ElementStatus>,
    actions: Vec<ElementStatus>,
    /// Story name -> its acts.
    stories: Vec<(String, Vec<usize>)>,
    names: HashMap<String, (Level, usize)>,
    /// The first element of each name at each level.
    typed: HashMap<(Level, String), usize>,
    variables: Vec<(String, VarValue)>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Level {
    Story,
    Act,
    Group,
    Maneuver,
    Event,
    Action,
}

impl Elements {
    fn status(&self, name: &str) -> Option<ElementStatus> {
        let (level, i) = *self.names.get(name)?;
        self.status_at(level, i)
    }

    fn status_of(&self, name: &str, kind: ElementKind) -> Option<ElementStatus> {
        let level = match kind {
            ElementKind::Story => Level::Story,
            ElementKind::Act => Level::Act,
            ElementKind::ManeuverGroup => Level::Group,
            ElementKind::Maneuver => Level::Maneuver,
            ElementKind::Event => Level::Event,
            ElementKind::Action => Level::Action,
        };
        let i = *self.typed.get(&(level, name.to_string()))?;
        self.status_at(level, i)
    }

    fn status_at(&self, level: Level, i: usize) -> Option<ElementStatus> {
        match level {
            Level::Act => self.acts.get(i).copied(),
            Level::Group => self.groups.get(i).copied(),
            Level::Maneuver => self.maneuvers.get(i).copied(),
            Level::Event => self.events.get(i).copied(),
            Level::Action => self.actions.get(i).copied(),
            Level::Story => {
                let (_, acts) = self.stories.get(i)?;
                let all = |f: &dyn Fn(&ElementStatus) -> bool| acts.iter().all(|&a| self.acts.get(a).is_some_and(f));
                let any_running = acts.iter().any(|&a| self.acts.get(a).is_some_and(|s| s.running));
                let complete = all(&|s| s.complete);
                let started = acts.iter().any(|&a| self.acts.get(a).is_some_and(|s| s.last.is_some()));
                let last = if complete {
                    Some(ElementEvent::EndTransition)
                } else if started {
                    Some(ElementEvent::StartTransition)
                } else {
                    None
                };
                Some(ElementStatus { running: any_running || (started && !complete), complete, last })
            }
        }
    }
}

/// A [`WorldView`] that answers entities from the simulation and elements and variables from the
/// story.
struct View<'a> {
    world: &'a dyn WorldView,
    elements: &'a Elements,
}

impl WorldView for View<'_> {
    fn entity(&self, name: &str) -> Option<EntityState> {
        self.world.entity(name)
    }
    fn phase(&self, name: &str, phase: usize) -> PhaseStatus {
        self.world.phase(name, phase)
    }
    fn element(&self, name: &str) -> Option<ElementStatus> {
        self.elements.status(name)
    }
    fn element_of(&self, name: &str, kind: Option<ElementKind>) -> Option<ElementStatus> {
        match kind {
            Some(k) => self.elements.status_of(name, k),
            None => self.elements.status(name),
        }
    }
    fn variable(&self, name: &str) -> Option<VarValue> {
        self.elements.variables.iter().find(|(n, _)| n == name).map(|(_, v)| v.clone())
    }
    fn collided(&self, a: &str, b: Option<&str>) -> bool {
        self.world.collided(a, b)
    }
    fn pose(&self, name: &str) -> Option<[f64; 3]> {
        self.world.pose(name)
    }
    fn place(&self, s: f64, offset: f64) -> Option<[f64; 4]> {
        self.world.place(s, offset)
    }
}

/// The running storyboard: call [`StoryState::step`] once per physics step (before the
/// entities move), run the actions it starts, and report the ones that end
/// ([`StoryState::end_action`]).
#[derive(Debug, Clone)]
pub struct StoryState {
    e: Elements,
    /// Parent indices.
    event_maneuver: Vec<usize>,
    action_path: Vec<Path>,
    /// Children of each element (contiguous in document order).
    act_groups: Vec<std::ops::Range<usize>>,
    group_maneuvers: Vec<std::ops::Range<usize>>,
    maneuver_events: Vec<std::ops::Range<usize>>,
    event_actions: Vec<std::ops::Range<usize>>,
    /// The event of each action.
    action_event: Vec<usize>,
    /// `max_executions` of each event.
    max_exec: Vec<u32>,
    act_start: Vec<TriggerState>,
    act_stop: Vec<TriggerState>,
    event_start: Vec<TriggerState>,
    executions: Vec<u32>,
    /// Actors still running each action.
    actors_left: Vec<usize>,
    /// Time of the evaluation being processed (the start of the step), s.
    now: f64,
    /// Every transition of an event or action: `(time, event?, index, transition)`.
    log: Vec<Transition>,
    /// Which act / event triggers fired this step (reused).
    fired_acts: Vec<usize>,
    stopped_acts: Vec<usize>,
}

fn start(s: &mut ElementStatus) {
    s.running = true;
    s.complete = false;
    s.last = Some(ElementEvent::StartTransition);
}

fn finish(s: &mut ElementStatus, how: ElementEvent) {
    s.running = false;
    s.complete = true;
    s.last = Some(how);
}

impl StoryState {
    /// The initial state of `story` (everything in standby, variables at their initial values).
    pub fn new(story: &Story) -> Self {
        let mut e = Elements {
            acts: Vec::new(),
            groups: Vec::new(),
            maneuvers: Vec::new(),
            events: Vec::new(),
            actions: Vec::new(),
            stories: Vec::new(),
            names: HashMap::new(),
            typed: HashMap::new(),
            variables: story.variables.iter().map(|v| (v.name.clone(), v.value.clone())).collect(),
        };
        let (mut event_maneuver, mut action_path, mut event_actions) = (Vec::new(), Vec::new(), Vec::new());
        let (mut act_groups, mut group_maneuvers, mut maneuver_events, mut action_event, mut max_exec) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut typed = HashMap::new();
        let mut name = |names: &mut HashMap<String, (Level, usize)>, n: &str, level: Level, i: usize| {
            names.entry(n.to_string()).or_insert((level, i));
            typed.entry((level, n.to_string())).or_insert(i);
        };
        for (ai, a) in story.acts.iter().enumerate() {
            if !a.story.is_empty() {
                match e.stories.iter_mut().find(|(n, _)| *n == a.story) {
                    Some((_, acts)) => acts.push(ai),
                    None => {
                        name(&mut e.names, &a.story, Level::Story, e.stories.len());
                        e.stories.push((a.story.clone(), vec![ai]));
                    }
                }
            }
            name(&mut e.names, &a.name, Level::Act, ai);
            e.acts.push(ElementStatus::default());
            let g0 = e.groups.len();
            for (gi, g) in a.groups.iter().enumerate() {
                let gidx = e.groups.len();
                name(&mut e.names, &g.name, Level::Group, gidx);
                e.groups.push(ElementStatus::default());
                let m0 = e.maneuvers.len();
                for (mi, m) in g.maneuvers.iter().enumerate() {
                    let midx = e.maneuvers.len();
                    name(&mut e.names, &m.name, Level::Maneuver, midx);
                    e.maneuvers.push(ElementStatus::default());
                    let e0 = e.events.len();
                    for (ei, ev) in m.events.iter().enumerate() {
                        let eidx = e.events.len();
                        name(&mut e.names, &ev.name, Level::Event, eidx);
                        e.events.push(ElementStatus::default());
                        event_maneuver.push(midx);
                        max_exec.push(ev.max_executions);
                        let first = e.actions.len();
                        for (xi, x) in ev.actions.iter().enumerate() {
                            name(&mut e.names, &x.name, Level::Action, e.actions.len());
                            e.actions.push(ElementStatus::default());
                            action_path.push((ai, gi, mi, ei, xi));
                            action_event.push(eidx);
                        }
                        event_actions.push(first..e.actions.len());
                    }
                    maneuver_events.push(e0..e.events.len());
                }
                group_maneuvers.push(m0..e.maneuvers.len());
            }
            act_groups.push(g0..e.groups.len());
        }
        e.typed = typed;
        let n_acts = e.acts.len();
        let n_events = e.events.len();
        let n_actions = e.actions.len();
        Self {
            e,
            event_maneuver,
            action_path,
            act_groups,
            group_maneuvers,
            maneuver_events,
            event_actions,
            action_event,
            max_exec,
            act_start: vec![TriggerState::new(); n_acts],
            act_stop: vec![TriggerState::new(); n_acts],
            event_start: vec![TriggerState::new(); n_events],
            executions: vec![0; n_events],
            actors_left: vec![0; n_actions],
            now: 0.0,
            log: Vec::new(),
            fired_acts: Vec::new(),
            stopped_acts: Vec::new(),
        }
    }

    /// The action with index `i` and the actors it runs on.
    pub fn action<'s>(&self, story: &'s Story, i: usize) -> Option<(&'s Action, &'s [String])> {
        let &(a, g, m, e, x) = self.action_path.get(i)?;
        let group = story.acts.get(a)?.groups.get(g)?;
        let action = &group.maneuvers.get(m)?.events.get(e)?.actions.get(x)?.action;
        Some((action, &group.actors))
    }

    /// The status of element `name` (story, act, group, maneuver, event or action).
    pub fn element(&self, name: &str) -> Option<ElementStatus> {
        self.e.status(name)
    }

    /// The value of variable `name`.
    pub fn variable(&self, name: &str) -> Option<&VarValue> {
        self.e.variables.iter().find(|(n, _)| n == name).map(|(_, v)| v)
    }

    /// `true` once every act is complete (or there is none).
    pub fn complete(&self) -> bool {
        self.e.acts.iter().all(|a| a.complete)
    }

    /// One evaluation at time `t` on `world`'s ground truth: starts acts and events whose
    /// triggers fire, stops acts whose stop trigger fires. Pushes the motion actions to run to
    /// `started` and the running actions that were stopped to `stopped` (the caller stops them
    /// on their actors). Variable and controller actions take effect and end at once (they are
    /// pushed to `started` too, so that the caller can apply controller actions).
    pub fn step(&mut self, story: &Story, world: &dyn WorldView, t: f64, started: &mut Vec<Started>, stopped: &mut Vec<usize>) {
        self.now = t;
        // Acts: start triggers (on the state at the start of the step).
        self.fired_acts.clear();
        {
            let view = View { world, elements: &self.e };
            for (i, a) in story.acts.iter().enumerate() {
                let st = self.e.acts[i];
                if st.running || st.complete {
                    continue;
                }
                let fire = match &a.start {
                    None => true,
                    Some(trig) => self.act_start[i].update(trig, &view, t),
                };
                if fire {
                    self.fired_acts.push(i);
                }
            }
        }
        for k in 0..self.fired_acts.len() {
            let i = self.fired_acts[k];
            self.start_act(i);
        }
        // Events of running maneuvers (including those started just now), in document order:
        // each one sees what the events before it did in this step (variables, states), as in
        // esmini.
        let mut idx = 0;
        for a in &story.acts {
            for g in &a.groups {
                for m in &g.maneuvers {
                    for ev in &m.events {
                        let i = idx;
                        idx += 1;
                        let st = self.e.events[i];
                        let running_maneuver = self.e.maneuvers.get(self.event_maneuver[i]).is_some_and(|s| s.running);
                        if st.running || st.complete || !running_maneuver {
                            continue;
                        }
                        let fire = match &ev.start {
                            None => true,
                            Some(trig) => {
                                let view = View { world, elements: &self.e };
                                self.event_start[i].update(trig, &view, t)
                            }
                        };
                        if fire {
                            self.start_event(story, i, started, stopped);
                        }
                    }
                }
            }
        }
        // Act stop triggers.
        self.stopped_acts.clear();
        {
            let view = View { world, elements: &self.e };
            for (i, a) in story.acts.iter().enumerate() {
                if let (true, Some(trig)) = (self.e.acts[i].running, &a.stop) {
                    if self.act_stop[i].update(trig, &view, t) {
                        self.stopped_acts.push(i);
                    }
                }
            }
        }
        for k in 0..self.stopped_acts.len() {
            let i = self.stopped_acts[k];
            self.stop_act(i, stopped);
        }
        self.settle();
    }

    fn note(&mut self, event: bool, index: usize, what: ElementEvent) {
        if self.log.len() < MAX_LOG {
            self.log.push(Transition { t: self.now, event, index, what });
        }
    }

    /// Every start / end / stop / skip of an event or action so far, in order.
    pub fn transitions(&self) -> &[Transition] {
        &self.log
    }

    /// The name of event `i` (`event`) or action `i` of `story`.
    pub fn name<'s>(&self, story: &'s Story, event: bool, i: usize) -> Option<&'s str> {
        let x = if event { self.event_actions.get(i)?.start } else { i };
        let &(a, g, m, e, k) = self.action_path.get(x)?;
        let ev = story.acts.get(a)?.groups.get(g)?.maneuvers.get(m)?.events.get(e)?;
        Some(if event { ev.name.as_str() } else { ev.actions.get(k)?.name.as_str() })
    }

    fn start_act(&mut self, i: usize) {
        start(&mut self.e.acts[i]);
        for g in self.act_groups[i].clone() {
            start(&mut self.e.groups[g]);
            for m in self.group_maneuvers[g].clone() {
                start(&mut self.e.maneuvers[m]);
            }
        }
    }

    fn start_event(&mut self, story: &Story, i: usize, started: &mut Vec<Started>, stopped: &mut Vec<usize>) {
        let m = self.event_maneuver[i];
        let Some(&(a, g, mi, ei, _)) = self.event_actions.get(i).and_then(|r| self.action_path.get(r.start)) else { return };
        let Some(ev) = story.acts.get(a).and_then(|x| x.groups.get(g)).and_then(|x| x.maneuvers.get(mi)).and_then(|x| x.events.get(ei))
        else {
            return;
        };
        let siblings: Vec<usize> = self.maneuver_events[m].clone().filter(|&j| j != i && self.e.events[j].running).collect();
        match ev.priority {
            Priority::Skip if !siblings.is_empty() => {
                self.e.events[i].last = Some(ElementEvent::SkipTransition);
                self.note(true, i, ElementEvent::SkipTransition);
                self.event_start[i] = TriggerState::new();
                return;
            }
            Priority::Override => {
                for j in siblings {
                    self.stop_event(j, stopped);
                }
            }
            _ => {}
        }
        self.executions[i] += 1;
        start(&mut self.e.events[i]);
        self.note(true, i, ElementEvent::StartTransition);
        let n_actors = story.acts.get(a).and_then(|x| x.groups.get(g)).map_or(0, |x| x.actors.len());
        let range = self.event_actions[i].clone();
        for x in range {
            start(&mut self.e.actions[x]);
            self.note(false, x, ElementEvent::StartTransition);
            started.push(Started { action: x });
            let Some((action, _)) = self.action(story, x) else { continue };
            match action {
                Action::VariableSet { variable, value } => {
                    if let Some(slot) = self.e.variables.iter_mut().find(|(n, _)| n == variable) {
                        slot.1 = value.clone();
                    }
                    self.actors_left[x] = 0;
                    self.end_now(x, ElementEvent::EndTransition);
                }
                Action::VariableModify { variable, add, multiply } => {
                    if let Some((_, VarValue::Num(v))) = self.e.variables.iter_mut().find(|(n, _)| n == variable) {
                        *v = *v * multiply.unwrap_or(1.0) + add.unwrap_or(0.0);
                    }
                    self.actors_left[x] = 0;
                    self.end_now(x, ElementEvent::EndTransition);
                }
                Action::Controller { .. } => {
                    self.actors_left[x] = 0;
                    self.end_now(x, ElementEvent::EndTransition);
                }
                _ if n_actors == 0 => self.end_now(x, ElementEvent::EndTransition),
                _ => self.actors_left[x] = n_actors,
            }
        }
    }

    fn stop_event(&mut self, i: usize, stopped: &mut Vec<usize>) {
        for x in self.event_actions[i].clone() {
            if self.e.actions[x].running {
                finish(&mut self.e.actions[x], ElementEvent::StopTransition);
                self.note(false, x, ElementEvent::StopTransition);
                self.actors_left[x] = 0;
                stopped.push(x);
            }
        }
        finish(&mut self.e.events[i], ElementEvent::StopTransition);
        self.note(true, i, ElementEvent::StopTransition);
    }

    fn stop_act(&mut self, i: usize, stopped: &mut Vec<usize>) {
        for g in self.act_groups[i].clone() {
            for m in self.group_maneuvers[g].clone() {
                for ev in self.maneuver_events[m].clone() {
                    if self.e.events[ev].running {
                        self.stop_event(ev, stopped);
                    } else if !self.e.events[ev].complete {
                        finish(&mut self.e.events[ev], ElementEvent::StopTransition);
                    }
                }
                if !self.e.maneuvers[m].complete {
                    finish(&mut self.e.maneuvers[m], ElementEvent::StopTransition);
                }
            }
            if !self.e.groups[g].complete {
                finish(&mut self.e.groups[g], ElementEvent::StopTransition);
            }
        }
        finish(&mut self.e.acts[i], ElementEvent::StopTransition);
    }

    /// Action `i` ended on one of its actors (`stopped`: replaced by another action of the same
    /// domain, or its actor left the story's control); it ends when it has ended on all of them.
    pub fn end_action(&mut self, i: usize, stopped: bool) {
        let Some(left) = self.actors_left.get_mut(i) else { return };
        if *left == 0 || !self.e.actions[i].running {
            return;
        }
        *left -= 1;
        if *left == 0 {
            self.end_now(i, if stopped { ElementEvent::StopTransition } else { ElementEvent::EndTransition });
        }
    }

    /// Ends action `i` and, once all its actions are complete, its event (back to standby
    /// while it has executions left).
    fn end_now(&mut self, i: usize, how: ElementEvent) {
        finish(&mut self.e.actions[i], how);
        self.note(false, i, how);
        let Some(&ev) = self.action_event.get(i) else { return };
        if !self.e.events[ev].running || !self.event_actions[ev].clone().all(|x| self.e.actions[x].complete) {
            return;
        }
        finish(&mut self.e.events[ev], ElementEvent::EndTransition);
        self.note(true, ev, ElementEvent::EndTransition);
        if self.executions[ev] < self.max_executions(ev) {
            self.e.events[ev].complete = false;
            self.event_start[ev] = TriggerState::new();
        }
        self.settle();
    }

    fn max_executions(&self, ev: usize) -> u32 {
        self.max_exec.get(ev).copied().unwrap_or(1)
    }

    /// Completes maneuvers, groups and acts whose children are all complete (linear in the
    /// number of elements).
    fn settle(&mut self) {
        for m in 0..self.e.maneuvers.len() {
            if self.e.maneuvers[m].running && self.maneuver_events[m].clone().all(|ev| self.e.events[ev].complete) {
                finish(&mut self.e.maneuvers[m], ElementEvent::EndTransition);
            }
        }
        for g in 0..self.e.groups.len() {
            if self.e.groups[g].running && self.group_maneuvers[g].clone().all(|m| self.e.maneuvers[m].complete) {
                finish(&mut self.e.groups[g], ElementEvent::EndTransition);
            }
        }
        for a in 0..self.e.acts.len() {
            if self.e.acts[a].running && self.act_groups[a].clone().all(|g| self.e.groups[g].complete) {
                finish(&mut self.e.acts[a], ElementEvent::EndTransition);
            }
        }
    }
}
