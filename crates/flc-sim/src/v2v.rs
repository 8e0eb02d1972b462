//! The V2V link: the lead broadcasts its speed; the follower receives some of the messages, late.
//!
//! Model (see `docs/v2v-and-metrics.md` for the full description):
//!
//! * **Schedule.** The lead broadcasts every `1 / rate_hz` seconds, starting at the first
//!   [`V2vChannel::tick`]; broadcasts are slotted on the grid `t0 + k / rate_hz` (no drift when the
//!   caller's tick does not divide the period; a broadcast happens on the first tick at or after
//!   its slot, missed slots are skipped, not bunched).
//! * **Delay.** Each message arrives `latency + U(-jitter, +jitter)` seconds after it was sent
//!   (uniform jitter, clamped so that the delay is never negative).
//! * **Random loss.** A message is lost with probability `loss_prob`, independently, *or* by the
//!   optional Gilbert–Elliott chain (bursty loss), whichever says "lost".
//! * **Outages.** The link is down during each window `[start, end)` of `outages` and during any
//!   outage started at run time ([`V2vChannel::start_outage`], e.g. at the lead's brake onset for
//!   `outage_on_brake`). A message is lost if its flight `[t_send, t_arrive]` overlaps a window:
//!   nothing arrives inside a window and the first message after it arrives `latency` after `end`.
//! * **Delivery.** [`V2vChannel::receive`] returns the newest message (highest sequence number)
//!   that has arrived by `t_now`; older ones that arrived in the same call, and any message older
//!   than one already delivered, are dropped ("superseded").
//! * **Clock skew.** The lead stamps messages with its own clock (`t_send + clock_skew_s`). The
//!   stamp is only informational: the supervisor judges freshness by counting its own control
//!   ticks since the last message, so no clock synchronisation is needed and the skew has no effect
//!   on control. That is the point of the parameter.
//!
//! * **Message contents.** Besides the speed and a sequence number, a message may carry the
//!   sender's CAM / BSM kinematics ([`flc_core::SenderState`]: station id, reference position,
//!   heading, acceleration, length; [`V2vChannel::send_state`]). The position carries the
//!   sender's GNSS error ([`crate::gnss`], `[v2v.gnss]`), sampled when the message is generated.
//!
//! Determinism: one ChaCha8 stream per channel (and one for the sender's GNSS error), seeded by the caller; every broadcast draws exactly
//! four uniforms (Gilbert–Elliott transition, Gilbert–Elliott loss, independent loss, jitter)
//! whatever the configuration, so changing e.g. `loss_prob` does not reshuffle the jitter draws.

use std::collections::VecDeque;

use flc_core::{SenderState, V2vMessage};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, check_range};
use crate::gnss::{GnssError, GnssParams};

/// Tolerance on time comparisons (s): a tick at `0.09999999999` counts as `0.1`.
const TIME_EPS: f64 = 1e-9;

/// Bursty loss: a two-state (good/bad) Markov chain stepped once per broadcast message.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GilbertElliott {
    /// Probability of going from the good to the bad state at a broadcast, in [0, 1].
    pub p_good_to_bad: f64,
    /// Probability of going from the bad to the good state at a broadcast, in [0, 1].
    pub p_bad_to_good: f64,
    /// Loss probability in the good state, in [0, 1]. Default 0.
    #[serde(default)]
    pub loss_good: f64,
    /// Loss probability in the bad state, in [0, 1]. Default 1 (Gilbert's original model).
    #[serde(default = "one")]
    pub loss_bad: f64,
}

fn one() -> f64 {
    1.0
}

impl GilbertElliott {
    /// Stationary probability of the bad state, `p_gb / (p_gb + p_bg)` (0 if both are 0).
    pub fn stationary_bad(&self) -> f64 {
        let s = self.p_good_to_bad + self.p_bad_to_good;
        if s > 0.0 { self.p_good_to_bad / s } else { 0.0 }
    }

    /// Long-run loss rate of the chain alone.
    pub fn mean_loss(&self) -> f64 {
        let pb = self.stationary_bad();
        (1.0 - pb) * self.loss_good + pb * self.loss_bad
    }

    fn validate(&self) -> Result<(), ConfigError> {
        check_range("p_good_to_bad", self.p_good_to_bad, 0.0, 1.0, "")?;
        check_range("p_bad_to_good", self.p_bad_to_good, 0.0, 1.0, "")?;
        check_range("loss_good", self.loss_good, 0.0, 1.0, "")?;
        check_range("loss_bad", self.loss_bad, 0.0, 1.0, "")
    }
}

/// A scripted outage: nothing is on the air during `[start, end)` (simulation time, s).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Outage {
    /// Start, s (>= 0).
    pub start: f64,
    /// End, s (> `start`; may be `inf` in TOML for "until the end of the run").
    pub end: f64,
}

impl Outage {
    /// `true` if a message in flight during `[t_send, t_arrive]` is hit by this outage.
    fn hits(&self, t_send: f64, t_arrive: f64) -> bool {
        t_send < self.end - TIME_EPS && t_arrive >= self.start - TIME_EPS
    }

    /// `true` if the link is down at `t`.
    fn covers(&self, t: f64) -> bool {
        t >= self.start - TIME_EPS && t < self.end - TIME_EPS
    }
}

/// Parameters of the V2V link (TOML table `[v2v]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct V2vParams {
    /// `false`: the lead never broadcasts (FLC-only runs). Default `true`.
    pub enabled: bool,
    /// Broadcast rate, Hz, in [0.1, 1000]. Default 10.
    pub rate_hz: f64,
    /// Mean one-way delay, s, in [0, 10]. Default 0.02.
    pub latency: f64,
    /// Half-width of the uniform delay jitter, s, in [0, 1]: delay = latency + U(-jitter, +jitter),
    /// clamped at 0. Default 0.005.
    pub jitter: f64,
    /// Independent per-message loss probability, in [0, 1]. Default 0.
    pub loss_prob: f64,
    /// Bursty loss on top of `loss_prob`. Default none.
    pub gilbert_elliott: Option<GilbertElliott>,
    /// Scripted outage windows. Default none.
    pub outages: Vec<Outage>,
    /// Lose the link for good from the lead's brake onset (the closed loop calls
    /// [`V2vChannel::start_outage`]). Default `false`.
    pub outage_on_brake: bool,
    /// Offset of the lead's clock, s, in [-1e6, 1e6]; only changes the stamps in the messages,
    /// which the supervisor never reads (no clock synchronisation needed). Default 0.
    pub clock_skew_s: f64,
    /// GNSS error of the sender's position in the messages (and of the receiver's own fix).
    /// Default 1 m sigma, 60 s correlation time.
    pub gnss: GnssParams,
}

impl Default for V2vParams {
    fn default() -> Self {
        Self {
            enabled: true,
            rate_hz: 10.0,
            latency: 0.02,
            jitter: 0.005,
            loss_prob: 0.0,
            gilbert_elliott: None,
            outages: Vec::new(),
            outage_on_brake: false,
            clock_skew_s: 0.0,
            gnss: GnssParams::default(),
        }
    }
}

/// Most `outages` of a link (each message is checked against every one).
pub const MAX_OUTAGES: usize = 1000;

impl V2vParams {
    /// Checks every value; the error names the key (relative to the `v2v` table) and the range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.outages.len() > MAX_OUTAGES {
            return Err(ConfigError::new("outages", format!("at most {MAX_OUTAGES} outages, got {}", self.outages.len())));
        }
        check_range("rate_hz", self.rate_hz, 0.1, 1000.0, "Hz")?;
        check_range("latency", self.latency, 0.0, 10.0, "s")?;
        check_range("jitter", self.jitter, 0.0, 1.0, "s")?;
        check_range("loss_prob", self.loss_prob, 0.0, 1.0, "")?;
        if let Some(ge) = &self.gilbert_elliott {
            ge.validate().map_err(|e| e.within("gilbert_elliott"))?;
        }
        for (i, o) in self.outages.iter().enumerate() {
            let key = format!("outages[{i}]");
            check_range("start", o.start, 0.0, 1e7, "s").map_err(|e| e.within(&key))?;
            if o.end.is_nan() || o.end <= o.start {
                return Err(ConfigError::new(format!("{key}.end"), format!("must be > start ({}) s, got {}", o.start, o.end)));
            }
        }
        check_range("clock_skew_s", self.clock_skew_s, -1e6, 1e6, "s")?;
        self.gnss.validate().map_err(|e| e.within("gnss"))
    }

    /// Broadcast period, s.
    pub fn period(&self) -> f64 {
        1.0 / self.rate_hz
    }
}

/// A message on the air, with the channel's bookkeeping.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct V2vPacket {
    /// What the follower's supervisor sees.
    pub message: V2vMessage,
    /// Send time, simulation clock, s.
    pub t_send: f64,
    /// Arrival time, simulation clock, s.
    pub t_arrive: f64,
    /// Send time on the lead's (skewed) clock, s. Informational only.
    pub stamp: f64,
    seq_full: u64,
}

/// Counters of a channel. `sent = lost_random + lost_outage + delivered + superseded + in flight`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct V2vStats {
    /// Messages broadcast.
    pub sent: u64,
    /// Lost to `loss_prob` or the Gilbert–Elliott chain.
    pub lost_random: u64,
    /// Lost to an outage window.
    pub lost_outage: u64,
    /// Handed to the receiver.
    pub delivered: u64,
    /// Arrived but dropped because a newer message arrived in the same `receive` call or had
    /// already been delivered.
    pub superseded: u64,
}

impl V2vStats {
    /// All losses.
    pub fn lost(&self) -> u64 {
        self.lost_random + self.lost_outage
    }
}

/// The lossy, delayed V2V link of one run.
#[derive(Debug, Clone)]
pub struct V2vChannel {
    params: V2vParams,
    rng: ChaCha8Rng,
    /// Next broadcast slot, s (`None` before the first tick).
    next_slot: Option<f64>,
    next_seq: u64,
    ge_bad: bool,
    in_flight: VecDeque<V2vPacket>,
    runtime_outages: Vec<Outage>,
    last_delivered: Option<u64>,
    stats: V2vStats,
    gnss: GnssError,
}

impl V2vChannel {
    /// Builds the channel; `params` should have been validated. Deterministic per `seed`.
    pub fn new(params: V2vParams, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        // Initial Gilbert–Elliott state from the stationary distribution (always drawn).
        let u: f64 = rng.random();
        let ge_bad = params.gilbert_elliott.is_some_and(|ge| u < ge.stationary_bad());
        let gnss = GnssError::new(params.gnss, seed ^ 0x474E_5353_5345_4E44); // "GNSSSEND"
        Self {
            gnss,
            params,
            rng,
            next_slot: None,
            next_seq: 0,
            ge_bad,
            in_flight: VecDeque::new(),
            runtime_outages: Vec::new(),
            last_delivered: None,
            stats: V2vStats::default(),
        }
    }

    /// The parameters.
    pub fn params(&self) -> &V2vParams {
        &self.params
    }

    /// The counters so far.
    pub fn stats(&self) -> V2vStats {
        self.stats
    }

    /// Messages sent and not yet delivered, lost or superseded.
    pub fn in_flight(&self) -> usize {
        self.in_flight.len()
    }

    /// One control/physics tick at time `t` (s): broadcasts `lead_speed` (m/s) if a slot is due,
    /// then returns the newest message that has arrived by `t`, if any. Call it every tick, with
    /// non-decreasing `t`.
    pub fn tick(&mut self, t: f64, lead_speed: f64) -> Option<V2vMessage> {
        self.tick_packet(t, lead_speed).map(|p| p.message)
    }

    /// [`Self::tick`] returning the packet with its times and stamp.
    pub fn tick_packet(&mut self, t: f64, lead_speed: f64) -> Option<V2vPacket> {
        if self.broadcast_due(t) {
            self.send(t, lead_speed);
        }
        self.receive_packet(t)
    }

    /// `true` if a broadcast slot is due at `t` (the first call always is, when enabled).
    pub fn broadcast_due(&self, t: f64) -> bool {
        self.params.enabled && t.is_finite() && self.next_slot.is_none_or(|slot| t >= slot - TIME_EPS)
    }

    /// Broadcasts `lead_speed` at `t_send` and advances the schedule past `t_send` (missed slots
    /// are skipped). Does nothing when the link is disabled or `t_send` is not finite.
    pub fn send(&mut self, t_send: f64, lead_speed: f64) {
        self.send_state(t_send, lead_speed, None);
    }

    /// [`Self::tick`] for a sender that broadcasts its kinematics (`truth`: true values; the
    /// message's position gets the sender's GNSS error).
    pub fn tick_state(&mut self, t: f64, lead_speed: f64, truth: &SenderState) -> Option<V2vMessage> {
        if self.broadcast_due(t) {
            self.send_state(t, lead_speed, Some(truth));
        }
        self.receive_packet(t).map(|p| p.message)
    }

    /// [`Self::send`] with the sender's kinematics (`truth`: true values, `None`: speed only).
    pub fn send_state(&mut self, t_send: f64, lead_speed: f64, truth: Option<&SenderState>) {
        if !self.params.enabled || !t_send.is_finite() {
            return;
        }
        let period = self.params.period();
        // Slotted schedule: the message carries the slot time if the tick is within TIME_EPS of it.
        let slot = self.next_slot.unwrap_or(t_send);
        let t_send = t_send.max(slot.min(t_send + TIME_EPS));
        let mut next = slot + period;
        if next <= t_send + TIME_EPS {
            let k = ((t_send + TIME_EPS - slot) / period).floor() + 1.0;
            next = slot + k * period;
        }
        self.next_slot = Some(next);

        // Four draws per message, always.
        let u_ge_step: f64 = self.rng.random();
        let u_ge_loss: f64 = self.rng.random();
        let u_iid: f64 = self.rng.random();
        let u_jitter: f64 = self.rng.random();

        let seq_full = self.next_seq;
        self.next_seq += 1;
        self.stats.sent += 1;

        let mut lost = u_iid < self.params.loss_prob;
        if let Some(ge) = self.params.gilbert_elliott {
            let flip = if self.ge_bad { ge.p_bad_to_good } else { ge.p_good_to_bad };
            if u_ge_step < flip {
                self.ge_bad = !self.ge_bad;
            }
            let p = if self.ge_bad { ge.loss_bad } else { ge.loss_good };
            lost |= u_ge_loss < p;
        }
        if lost {
            self.stats.lost_random += 1;
            return;
        }
        let delay = (self.params.latency + self.params.jitter * (2.0 * u_jitter - 1.0)).max(0.0);
        let sender = truth.map(|s| {
            let (ex, ey) = self.gnss.sample(t_send);
            SenderState { x: s.x + ex, y: s.y + ey, ..*s }
        });
        self.in_flight.push_back(V2vPacket {
            message: V2vMessage { lead_speed, seq: seq_full as u32, sender },
            t_send,
            t_arrive: t_send + delay,
            stamp: t_send + self.params.clock_skew_s,
            seq_full,
        });
    }

    /// The newest message that has arrived by `t_now`, if any (see the module docs).
    pub fn receive(&mut self, t_now: f64) -> Option<V2vMessage> {
        self.receive_packet(t_now).map(|p| p.message)
    }

    /// [`Self::receive`] returning the packet with its times and stamp.
    pub fn receive_packet(&mut self, t_now: f64) -> Option<V2vPacket> {
        let mut best: Option<V2vPacket> = None;
        let mut i = 0;
        while i < self.in_flight.len() {
            let arrived = self.in_flight.get(i).is_some_and(|p| p.t_arrive <= t_now + TIME_EPS);
            if !arrived {
                i += 1;
                continue;
            }
            let Some(p) = self.in_flight.remove(i) else { break };
            if self.hit_by_outage(&p) {
                self.stats.lost_outage += 1;
            } else if self.last_delivered.is_some_and(|d| p.seq_full <= d) {
                self.stats.superseded += 1;
            } else {
                match best {
                    Some(b) if b.seq_full > p.seq_full => self.stats.superseded += 1,
                    Some(_) => {
                        self.stats.superseded += 1;
                        best = Some(p);
                    }
                    None => best = Some(p),
                }
            }
        }
        if let Some(b) = &best {
            self.stats.delivered += 1;
            self.last_delivered = Some(b.seq_full);
        }
        best
    }

    /// Takes the link down from `t` on, for good (until [`Self::end_outage`]). Idempotent: calling
    /// it again while such an outage is open (e.g. every tick after the brake onset) changes
    /// nothing. Messages in flight at `t` are lost too.
    pub fn start_outage(&mut self, t: f64) {
        if !t.is_finite() || self.runtime_outages.iter().any(|o| o.end == f64::INFINITY && o.start <= t) {
            return;
        }
        self.runtime_outages.push(Outage { start: t, end: f64::INFINITY });
    }

    /// Ends the outages opened by [`Self::start_outage`] at `t` (messages sent from `t` on get
    /// through again).
    pub fn end_outage(&mut self, t: f64) {
        for o in &mut self.runtime_outages {
            if o.end == f64::INFINITY {
                o.end = t.max(o.start);
            }
        }
        self.runtime_outages.retain(|o| o.end > o.start);
    }

    /// Starts (`active`) or ends an open-ended run-time outage at `t`.
    pub fn set_outage(&mut self, active: bool, t: f64) {
        if active { self.start_outage(t) } else { self.end_outage(t) }
    }

    /// `true` if the link is down at `t` (scripted or run-time outage).
    pub fn in_outage(&self, t: f64) -> bool {
        self.params.outages.iter().chain(&self.runtime_outages).any(|o| o.covers(t))
    }

    fn hit_by_outage(&self, p: &V2vPacket) -> bool {
        self.params.outages.iter().chain(&self.runtime_outages).any(|o| o.hits(p.t_send, p.t_arrive))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.01;

    /// Runs the channel at `DT` for `secs`, broadcasting `speed(t)`; returns (t, message) pairs.
    fn run(ch: &mut V2vChannel, secs: f64) -> Vec<(f64, V2vMessage)> {
        let n = (secs / DT).round() as u64;
        (0..n)
            .filter_map(|k| {
                let t = k as f64 * DT;
                ch.tick(t, t).map(|m| (t, m))
            })
            .collect()
    }

    fn ideal() -> V2vParams {
        V2vParams { jitter: 0.0, ..V2vParams::default() }
    }

    fn check_invariant(ch: &V2vChannel) {
        let s = ch.stats();
        assert_eq!(s.sent, s.lost() + s.delivered + s.superseded + ch.in_flight() as u64, "{s:?}");
    }

    #[test]
    fn ten_hz_lossless_delivers_about_100_in_10_s() {
        let mut ch = V2vChannel::new(V2vParams::default(), 1);
        let got = run(&mut ch, 10.0);
        assert!((99..=101).contains(&got.len()), "{}", got.len());
        let s = ch.stats();
        assert_eq!(s.lost(), 0);
        assert_eq!(s.superseded, 0);
        check_invariant(&ch);
        // Sequence numbers consecutive, speeds are the send times (our speed profile is t).
        for w in got.windows(2) {
            assert_eq!(w[1].1.seq, w[0].1.seq + 1);
        }
    }

    #[test]
    fn tick_rate_not_dividing_the_period_does_not_drift() {
        // 7 Hz broadcasts, 100 Hz ticks: 70 in 10 s.
        let mut ch = V2vChannel::new(V2vParams { rate_hz: 7.0, ..ideal() }, 1);
        let got = run(&mut ch, 10.0);
        assert!((69..=71).contains(&got.len()), "{}", got.len());
        // Coarse ticks (20 Hz) with a 10 Hz link: one message every other tick.
        let mut ch = V2vChannel::new(ideal(), 1);
        let mut n = 0;
        for k in 0..200 {
            if ch.tick(k as f64 * 0.05, 0.0).is_some() {
                n += 1;
            }
        }
        assert!((99..=100).contains(&n), "{n}");
    }

    #[test]
    fn independent_loss_within_binomial_4_sigma() {
        let p = 0.3;
        let mut ch = V2vChannel::new(V2vParams { loss_prob: p, ..V2vParams::default() }, 7);
        run(&mut ch, 1000.0);
        let s = ch.stats();
        let n = s.sent as f64;
        let sigma = (n * p * (1.0 - p)).sqrt();
        let expected_delivered = n * (1.0 - p);
        let d = s.delivered as f64 + ch.in_flight() as f64;
        assert!((d - expected_delivered).abs() < 4.0 * sigma, "delivered {d}, expected {expected_delivered} ± {}", 4.0 * sigma);
        check_invariant(&ch);
    }

    /// Mean length of runs of consecutive lost messages, seen from the received sequence numbers.
    fn mean_burst(got: &[(f64, V2vMessage)]) -> (f64, f64) {
        let mut bursts = Vec::new();
        for w in got.windows(2) {
            let gap = w[1].1.seq.wrapping_sub(w[0].1.seq);
            if gap > 1 {
                bursts.push(f64::from(gap - 1));
            }
        }
        let lost: f64 = bursts.iter().sum();
        let span = f64::from(got.last().map_or(0, |g| g.1.seq) - got.first().map_or(0, |g| g.1.seq));
        (lost / bursts.len().max(1) as f64, lost / span.max(1.0))
    }

    #[test]
    fn gilbert_elliott_bursts_are_longer_than_independent_loss_at_same_mean() {
        let ge = GilbertElliott { p_good_to_bad: 0.05, p_bad_to_good: 0.2, loss_good: 0.0, loss_bad: 1.0 };
        let mean = ge.mean_loss();
        assert!((mean - 0.2).abs() < 1e-12);
        let mut a = V2vChannel::new(V2vParams { gilbert_elliott: Some(ge), ..V2vParams::default() }, 3);
        let mut b = V2vChannel::new(V2vParams { loss_prob: mean, ..V2vParams::default() }, 3);
        let (burst_ge, loss_ge) = mean_burst(&run(&mut a, 3000.0));
        let (burst_iid, loss_iid) = mean_burst(&run(&mut b, 3000.0));
        // Same mean loss (30 000 messages: within a few percentage points) ...
        assert!((loss_ge - 0.2).abs() < 0.03, "{loss_ge}");
        assert!((loss_iid - 0.2).abs() < 0.02, "{loss_iid}");
        // ... but bursts of ~1 / p_bad_to_good = 5 messages against ~1 / (1 - 0.2) = 1.25.
        assert!((burst_ge - 5.0).abs() < 0.75, "{burst_ge}");
        assert!((burst_iid - 1.25).abs() < 0.1, "{burst_iid}");
        assert!(burst_ge > 3.0 * burst_iid);
        check_invariant(&a);
        check_invariant(&b);
    }

    #[test]
    fn scripted_outage_delivers_nothing_inside_and_resumes_after_latency() {
        let params = V2vParams { outages: vec![Outage { start: 3.0, end: 5.0 }], ..ideal() };
        let mut ch = V2vChannel::new(params, 1);
        let got = run(&mut ch, 10.0);
        assert!(got.iter().all(|(t, _)| *t < 3.0 || *t >= 5.0));
        let last_before = got.iter().filter(|(t, _)| *t < 3.0).map(|g| g.0).fold(f64::NAN, f64::max);
        let first_after = got.iter().find(|(t, _)| *t >= 5.0).map(|g| g.0);
        assert!((last_before - 2.92).abs() < 1e-9, "{last_before}");
        assert_eq!(first_after.map(|t| (t * 100.0).round() / 100.0), Some(5.02));
        assert!(ch.in_outage(4.0) && !ch.in_outage(5.0) && !ch.in_outage(2.9));
        // The 20 messages sent at 3.0, 3.1, ..., 4.9 are lost; the one sent at 2.9 arrived at 2.92.
        assert_eq!(ch.stats().lost_outage, 20);
        check_invariant(&ch);
    }

    #[test]
    fn run_time_outage_is_idempotent_and_loses_messages_in_flight() {
        let mut ch = V2vChannel::new(V2vParams { latency: 0.05, ..ideal() }, 1);
        let mut got = Vec::new();
        for k in 0..1000 {
            let t = k as f64 * DT;
            if t >= 2.03 {
                ch.start_outage(2.03); // called every tick after the onset, as the closed loop does
            }
            if ch.tick(t, 1.0).is_some() {
                got.push(t);
            }
        }
        // The message sent at 2.0 would arrive at 2.05, after the onset: lost.
        assert_eq!(got.last().copied().map(|t| (t * 100.0).round() / 100.0), Some(1.95));
        assert!(ch.in_outage(9.0));
        ch.end_outage(10.0);
        assert!(!ch.in_outage(10.5));
        assert!(ch.tick(10.0, 1.0).is_none());
        assert!(ch.tick(10.06, 1.0).is_some());
        check_invariant(&ch);
    }

    #[test]
    fn latency_delays_arrival() {
        for latency in [0.0, 0.02, 0.137] {
            let mut ch = V2vChannel::new(V2vParams { latency, ..ideal() }, 1);
            let mut first = None;
            for k in 0..200 {
                let t = k as f64 * 0.001;
                if let Some(p) = ch.tick_packet(t, 1.0) {
                    first = Some((t, p));
                    break;
                }
            }
            let (t, p) = first.expect("a message");
            assert_eq!(p.t_send, 0.0);
            assert!((p.t_arrive - latency).abs() < 1e-12);
            assert!(t >= latency - 1e-9 && t < latency + 0.001 + 1e-9, "{t} vs {latency}");
        }
        // Jitter stays within ±jitter around the latency.
        let mut ch = V2vChannel::new(V2vParams { latency: 0.05, jitter: 0.01, ..V2vParams::default() }, 9);
        for k in 0..5000 {
            if let Some(p) = ch.tick_packet(k as f64 * DT, 0.0) {
                let d = p.t_arrive - p.t_send;
                assert!((0.04 - 1e-12..=0.06 + 1e-12).contains(&d), "{d}");
            }
        }
    }

    #[test]
    fn clock_skew_only_changes_stamps() {
        let run_with = |skew: f64| {
            let mut ch = V2vChannel::new(V2vParams { clock_skew_s: skew, ..V2vParams::default() }, 5);
            (0..1000).filter_map(|k| ch.tick_packet(k as f64 * DT, 3.0)).collect::<Vec<_>>()
        };
        let (a, b) = (run_with(0.0), run_with(123.4));
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.message, y.message);
            assert_eq!(x.t_arrive, y.t_arrive);
            assert!((y.stamp - x.stamp - 123.4).abs() < 1e-9);
        }
    }

    #[test]
    fn same_seed_same_sequence_other_seed_differs() {
        let p = V2vParams {
            loss_prob: 0.2,
            jitter: 0.04,
            gilbert_elliott: Some(GilbertElliott { p_good_to_bad: 0.1, p_bad_to_good: 0.3, loss_good: 0.05, loss_bad: 0.9 }),
            ..V2vParams::default()
        };
        let trace = |seed| {
            let mut ch = V2vChannel::new(p.clone(), seed);
            (run(&mut ch, 100.0), ch.stats())
        };
        assert_eq!(trace(11), trace(11));
        assert_ne!(trace(11).0, trace(12).0);
    }

    #[test]
    fn disabled_link_sends_nothing() {
        let mut ch = V2vChannel::new(V2vParams { enabled: false, ..V2vParams::default() }, 1);
        assert!(run(&mut ch, 5.0).is_empty());
        assert_eq!(ch.stats(), V2vStats::default());
    }

    #[test]
    fn reordered_older_messages_are_superseded() {
        // Jitter larger than the period reorders; the receiver never goes back in sequence.
        let mut ch = V2vChannel::new(V2vParams { rate_hz: 100.0, latency: 0.1, jitter: 0.09, ..V2vParams::default() }, 2);
        let got = run(&mut ch, 20.0);
        assert!(got.windows(2).all(|w| w[1].1.seq > w[0].1.seq));
        assert!(ch.stats().superseded > 0);
        check_invariant(&ch);
    }

    #[test]
    fn validate_names_keys_and_ranges() {
        assert_eq!(V2vParams::default().validate(), Ok(()));
        let e = V2vParams { rate_hz: 0.0, ..V2vParams::default() }.validate().unwrap_err();
        assert_eq!(e.key, "rate_hz");
        assert!(e.problem.contains("[0.1, 1000]"), "{}", e.problem);
        let e = V2vParams { loss_prob: 1.5, ..V2vParams::default() }.validate().unwrap_err();
        assert_eq!(e.key, "loss_prob");
        let ge = GilbertElliott { p_good_to_bad: 0.1, p_bad_to_good: 1.2, loss_good: 0.0, loss_bad: 1.0 };
        let e = V2vParams { gilbert_elliott: Some(ge), ..V2vParams::default() }.validate().unwrap_err();
        assert_eq!(e.key, "gilbert_elliott.p_bad_to_good");
        let outages = vec![Outage { start: 1.0, end: 2.0 }, Outage { start: 3.0, end: 3.0 }];
        let e = V2vParams { outages, ..V2vParams::default() }.validate().unwrap_err();
        assert_eq!(e.key, "outages[1].end");
        let e = V2vParams { latency: f64::NAN, ..V2vParams::default() }.validate().unwrap_err();
        assert_eq!(e.key, "latency");
        assert_eq!(e.within("v2v").to_string(), "`v2v.latency`: must be in [0, 10] s, got NaN");
    }

    #[test]
    fn serde_defaults_and_unknown_fields() {
        let p: V2vParams =
            serde_json::from_str(r#"{"loss_prob": 0.1, "gilbert_elliott": {"p_good_to_bad": 0.1, "p_bad_to_good": 0.5}}"#).unwrap();
        assert_eq!(p.rate_hz, 10.0);
        assert_eq!(p.gilbert_elliott.map(|g| (g.loss_good, g.loss_bad)), Some((0.0, 1.0)));
        assert!(serde_json::from_str::<V2vParams>(r#"{"rate": 5}"#).is_err());
        let toml_p: V2vParams = toml::from_str("outages = [{ start = 1.0, end = inf }]").unwrap();
        assert_eq!(toml_p.outages[0].end, f64::INFINITY);
        assert_eq!(toml_p.validate(), Ok(()));
    }

    proptest::proptest! {
        #[test]
        fn counters_add_up_and_deliveries_are_ordered(
            seed in 0u64..1000,
            rate in 1.0f64..100.0,
            latency in 0.0f64..0.5,
            jitter in 0.0f64..0.3,
            loss in 0.0f64..1.0,
            step in 0.001f64..0.2,
        ) {
            let mut ch = V2vChannel::new(V2vParams { rate_hz: rate, latency, jitter, loss_prob: loss, outages: vec![Outage { start: 1.0, end: 2.0 }], ..V2vParams::default() }, seed);
            let mut last: Option<u32> = None;
            for k in 0..(5.0 / step) as u64 {
                let t = k as f64 * step;
                if let Some(m) = ch.tick(t, 1.0) {
                    proptest::prop_assert!(last.is_none_or(|l| m.seq > l));
                    last = Some(m.seq);
                }
            }
            let s = ch.stats();
            proptest::prop_assert_eq!(s.sent, s.lost() + s.delivered + s.superseded + ch.in_flight() as u64);
        }
    }
}
