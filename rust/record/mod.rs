//! What a run keeps: chosen joints' penetration, force and journal position, chosen nodes'
//! displacements, every k-th step from a start time; running extremes of every joint, which
//! cost O(joints) memory whatever the run length; and, when asked, an impact log per chosen joint
//! (one entry per impact, its rebounds included: memory grows with the number of impacts, not of
//! steps).
//!
//! One file per part: what to record (`spec.rs`), the histories and the sliders' reference
//! (`histories.rs`), a joint's running extremes and contact episodes (`extremes.rs`), the
//! recorder (`recorder.rs`) and its telling of impacts from rebounds (`impacts.rs`).

mod extremes;
mod histories;
mod impacts;
mod recorder;
mod spec;

pub use extremes::*;
pub use histories::*;
pub use recorder::*;
pub use spec::*;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reserve_now_keeps_the_samples_and_backs_the_room_with_memory() {
        let mut v: Vec<f64> = (0..10).map(f64::from).collect();
        let n = 1 << 19; // 4 MiB of room
        reserve_now(&mut v, n);
        assert!(v.capacity() >= 10 + n);
        assert_eq!(v, (0..10).map(f64::from).collect::<Vec<_>>());
        #[cfg(target_os = "linux")]
        {
            // every whole page of the room is resident before anything is written to it
            const PAGE: usize = 4096;
            let spare = v.spare_capacity_mut();
            let start = (spare.as_mut_ptr() as usize).next_multiple_of(PAGE);
            let end = (spare.as_mut_ptr() as usize + std::mem::size_of_val(spare)) / PAGE * PAGE;
            let pages = (end - start) / PAGE;
            let mut resident = vec![0u8; pages];
            // SAFETY: the range is mapped (inside `v`'s allocation); `resident` has a byte a page
            let rc = unsafe { libc::mincore(start as *mut libc::c_void, end - start, resident.as_mut_ptr()) };
            assert_eq!(rc, 0);
            // (MADV_POPULATE_WRITE came with Linux 5.14)
            let release = std::fs::read_to_string("/proc/sys/kernel/osrelease").unwrap_or_default();
            let mut parts = release
                .split(|c: char| !c.is_ascii_digit())
                .filter_map(|p| p.parse::<u32>().ok());
            let version = (parts.next().unwrap_or(0), parts.next().unwrap_or(0));
            if version >= (5, 14) {
                assert!(resident.iter().all(|&r| r & 1 == 1), "some pages were left unbacked");
            }
        }
        // room below PREFAULT_MIN_BYTES: a plain reserve
        let mut w: Vec<f64> = Vec::new();
        reserve_now(&mut w, 16);
        assert!(w.capacity() >= 16 && w.is_empty());
    }

    #[test]
    fn sums_of_squares_of_huge_values_stay_finite_and_ordinary_ones_are_untouched() {
        assert_eq!(SQUARE_SCALE_FROM, 2f64.powi(500));
        assert_eq!(DOWN, 2f64.powi(-600));
        // ordinary values: the plain sum, bit for bit
        let (mut sum, mut scaled) = (0.0, false);
        for x in [1e-6, -2.5e-5, 3.0] {
            add_square(&mut sum, &mut scaled, x);
        }
        assert!(!scaled);
        assert_eq!(sum, 1e-6 * 1e-6 + 2.5e-5 * 2.5e-5 + 3.0 * 3.0);
        // a clearance of 1e300 m: the RMS of (-1e300, -1e300, 2) is 1e300 sqrt(2/3)
        let (mut sum, mut scaled) = (0.0, false);
        for x in [2.0, -1e300, -1e300] {
            add_square(&mut sum, &mut scaled, x);
        }
        assert!(scaled);
        let rms = root_mean(sum, scaled, 3.0);
        assert!((rms / (1e300 * (2.0f64 / 3.0).sqrt()) - 1.0).abs() < 1e-15, "{rms}");
    }

    /// Drives a recorder through one joint's states: `(penetration, normal force, approach
    /// speed)` per step of `dt`, the journal on the +x axis.
    fn run(states: &[(f64, f64, f64)], dt: f64, start: f64) -> JointExtremes {
        let spec = RecordSpec {
            histories: false,
            contact_modes: true,
            start,
            ..RecordSpec::default()
        };
        let mut rec = Recorder::new(&spec, &[1e-3], |_, _| 0, states.len() as u64);
        let c = 1e-3;
        for (k, &(p, f, v)) in states.iter().enumerate() {
            rec.record(
                k as u64,
                k as f64 * dt,
                dt,
                &[p],
                &[[-f, 0.0]],
                &[[c + p, 0.0]],
                &[[v, 0.0]],
                &[],
            );
        }
        rec.extremes[0]
    }

    #[test]
    fn a_closing_after_a_shallow_separation_is_a_rebound_of_the_impact_going_on() {
        // clearance 1 mm: rebound depth 10 um. Closed, open by 2 um, closed (a rebound), open by
        // 50 um, closed (an impact), open by 10 um exactly (not deeper: a rebound), closed
        let states = [
            (-1e-4, 0.0, 1.0),
            (1e-6, 1.0, 1.0),
            (-2e-6, 0.0, -1.0),
            (2e-6, 3.0, 1.0),
            (-5e-5, 0.0, -1.0),
            (3e-6, 2.0, 1.0),
            (-1e-5, 0.0, -1.0),
            (1e-6, 1.0, 1.0),
            (-1e-6, 0.0, -1.0),
        ];
        let spec = RecordSpec {
            histories: false,
            impacts: true,
            ..RecordSpec::default()
        };
        let c = 1e-3;
        assert_eq!(REBOUND_DEPTH * c, 1e-5);
        let mut rec = Recorder::new(&spec, &[c], |_, _| 0, states.len() as u64);
        for (k, &(p, f, v)) in states.iter().enumerate() {
            let (q, qd) = ([c + p, 0.0], [v, 0.0]);
            rec.record(k as u64, k as f64, 1.0, &[p], &[[-f, 0.0]], &[q], &[qd], &[]);
        }
        let e = rec.extremes[0];
        assert_eq!((e.impacts, e.contact_episodes), (2, 4));
        let log = &rec.impacts[0].1;
        assert_eq!(log.len(), 2);
        // each entry spans its rebounds: entry, exit of the last rebound, peaks over them
        assert_eq!((log[0].time, log[0].duration), (1.0, 3.0 - 1.0 + 1.0));
        assert_eq!((log[0].peak_force, log[0].peak_penetration), (3.0, 2e-6));
        assert_eq!((log[1].time, log[1].duration), (5.0, 8.0 - 5.0));
        assert_eq!((log[1].peak_force, log[1].peak_penetration), (2.0, 3e-6));
        // the approach speed of an impact is that of the state before it (open)
        assert_eq!((log[0].speed, log[1].speed), (1.0, -1.0));
        assert_eq!(e.max_impact_velocity, 1.0);
    }

    #[test]
    fn an_impact_between_steps_takes_the_state_nearer_the_circle() {
        let spec = RecordSpec {
            histories: false,
            impacts: true,
            contact_modes: true,
            ..RecordSpec::default()
        };
        let c = 1e-3;
        let state = |p: f64, v: f64| ([c + p, 0.0], [v, 0.0]);
        // an adaptive cut just short of the circle (open, 1 m/s), then the substep after it,
        // closed and slowed by the contact (0.5 m/s): the impact is the cut's
        let mut rec = Recorder::new(&spec, &[c], |_, _| 0, 2);
        let (q, qd) = state(-1e-4, 1.0);
        rec.record(0, 0.0, 1e-5, &[-1e-4], &[[0.0; 2]], &[q], &[qd], &[]);
        let (q, qd) = state(-1e-10, 1.0);
        rec.record_substep(1e-6, &[-1e-10], &[[0.0; 2]], &[q], &[qd]);
        let (q, qd) = state(5e-8, 0.5);
        rec.record_substep(2e-6, &[5e-8], &[[-1.0, 0.0]], &[q], &[qd]);
        let log = &rec.impacts[0].1;
        assert_eq!((log.len(), log[0].time, log[0].speed), (1, 1e-6, 1.0));
        let ep = rec.extremes[0].episode.expect("an episode going on");
        assert_eq!((ep.entry, ep.speed), (1e-6, 1.0));
        // an event-aware fixed step cuts just past the circle: the closing state is the crossing,
        // the last open state a step before it
        let mut rec = Recorder::new(&spec, &[c], |_, _| 0, 2);
        let (q, qd) = state(-1e-5, 1.2);
        rec.record(0, 0.0, 1e-5, &[-1e-5], &[[0.0; 2]], &[q], &[qd], &[]);
        let (q, qd) = state(1e-10, 0.99);
        rec.record_event(7e-6, &[1e-10], &[[-1e-4, 0.0]], &[q], &[qd]);
        let log = &rec.impacts[0].1;
        assert_eq!((log[0].time, log[0].speed), (7e-6, 0.99));
        let ep = rec.extremes[0].episode.expect("an episode going on");
        assert_eq!((ep.entry, ep.speed), (7e-6, 0.99));
    }

    #[test]
    fn an_episode_located_by_cuts_is_classified_without_a_steps_slack() {
        let spec = RecordSpec {
            histories: false,
            contact_modes: true,
            ..RecordSpec::default()
        };
        let c = 1e-3;
        let mut rec = Recorder::new(&spec, &[c], |_, _| 0, 3);
        let mut at = |k: Option<u64>, t: f64, p: f64, v: f64| {
            let (q, qd, f) = ([c + p, 0.0], [v, 0.0], [-1e6 * p.max(0.0), 0.0]);
            match k {
                Some(k) => rec.record(k, t, 1e-5, &[p], &[f], &[q], &[qd], &[]),
                None => rec.record_substep(t, &[p], &[f], &[q], &[qd]),
            }
        };
        // entry at a cut at 1 us (1 m/s), peak 1 um: natural period pi 1e-6 s, five of them
        // 15.7 us; exit at a cut at 21 us: 20 us, continuous contact (with the output step's
        // 10 us of slack it counted as an impact)
        at(Some(0), 0.0, -1e-4, 1.0);
        at(None, 1e-6, -1e-12, 1.0);
        at(None, 2e-6, 1e-6, 0.0);
        at(Some(1), 1e-5, 5e-7, -0.1);
        at(Some(2), 2e-5, 1e-7, -0.1);
        at(None, 2.1e-5, -1e-12, -0.1);
        let e = rec.extremes[0];
        assert_eq!((e.continuous_time, e.impact_time), (2e-5, 0.0));
    }

    #[test]
    fn time_weighted_sums_count_each_state_up_to_the_next() {
        let spec = RecordSpec {
            histories: false,
            ..RecordSpec::default()
        };
        let c = 1e-3;
        let mut rec = Recorder::new(&spec, &[c], |_, _| 0, 2);
        rec.weigh_by_time();
        let at = |f: f64| [[-f, 0.0]];
        let q = [[c, 0.0]];
        let v = [[0.0; 2]];
        rec.record(0, 0.0, 1e-5, &[-1e-6], &at(0.0), &q, &v, &[]);
        rec.record_substep(1e-6, &[1e-6], &at(10.0), &q, &v);
        rec.record_substep(3e-6, &[2e-6], &at(20.0), &q, &v);
        // the same instant again (a cut's right limit): it replaces the state before
        rec.record_event(3e-6, &[2e-6], &at(30.0), &q, &v);
        rec.record(1, 4e-6, 1e-5, &[-1e-6], &at(0.0), &q, &v, &[]);
        let e = rec.extremes[0];
        // 0 for 1 us, 10 N for 2 us, 30 N for 1 us: (200 + 900) / 4 N^2
        assert!((e.weighted_time - 4e-6).abs() < 1e-18);
        assert!(
            (e.rms_force() - (1100.0f64 / 4.0).sqrt()).abs() < 1e-9,
            "{}",
            e.rms_force()
        );
        let pen = ((1e-12 + 2.0 * 1e-12 + 4e-12) / 4.0f64).sqrt();
        assert!((e.rms_penetration() - pen).abs() < 1e-15, "{}", e.rms_penetration());
    }

    #[test]
    fn the_work_of_a_linear_spring_telescopes_and_modes_sum_to_the_run() {
        // a linear spring k d over an episode up and down: no dissipation, bit for bit
        let k = 1e6;
        let ds = [-1e-6, 2e-7, 5e-7, 9e-7, 6e-7, 1e-7, -3e-7, -5e-7];
        let states: Vec<_> = ds
            .iter()
            .map(|&d: &f64| (d, k * d.max(0.0), if d > 0.0 { 1.0 } else { -1.0 }))
            .collect();
        let e = run(&states, 1e-7, 0.0);
        assert!(e.contact_work.abs() < 1e-20, "{}", e.contact_work);
        assert_eq!(e.dissipated_energy(), e.contact_work);
        assert_eq!(e.impacts, 1);
        // 5 closed steps of 1e-7 s, speed 1 m/s, peak 9e-7 m: (5e-7 - 1e-7) * 1 <= 5 pi 9e-7
        assert_eq!((e.impact_time, e.continuous_time), (e.contact_time, 0.0));
        let total = e.free_flight_fraction() + e.impact_fraction() + e.continuous_fraction();
        assert!((total - 1.0).abs() < 1e-15 && (e.free_flight_fraction() - 2.0 / 7.0).abs() < 1e-12);
        // a spring-dashpot that ends open dissipates the loop's area: F = k d + c dd
        let c = 50.0;
        let dt = 1e-7;
        let states: Vec<_> = ds
            .iter()
            .zip(ds.iter().skip(1))
            .map(|(&d0, &d1): (&f64, &f64)| {
                let rate = (d1 - d0) / dt;
                (d1, if d1 > 0.0 { k * d1 + c * rate } else { 0.0 }, rate)
            })
            .collect();
        assert!(run(&states, dt, 0.0).dissipated_energy() > 0.0);
    }

    #[test]
    fn contact_modes_follow_the_natural_period_rule() {
        let pi5 = CONTINUOUS_PERIODS * std::f64::consts::PI;
        // an impact of peak 1e-6 m at 1 m/s: the natural period is pi 1e-6 s
        assert!(!is_continuous(pi5 * 1e-6, 1.0, 1e-6, 1e-9));
        assert!(is_continuous(pi5 * 1e-6 + 2e-9, 1.0, 1e-6, 1e-9));
        // no approach: continuous; a single step: an impact
        assert!(is_continuous(1e-9, 0.0, 1e-6, 1e-9));
        assert!(!is_continuous(1e-3, 1.0, 0.0, 1e-3));
        // a journal resting on the wall from the start: all continuous contact, and the stored
        // spring energy is not counted as dissipated
        let states = vec![(1e-6, 1.0, 0.0); 100];
        let e = run(&states, 1e-5, 0.0);
        assert_eq!(e.impacts, 0);
        assert_eq!(
            (e.free_flight_fraction(), e.impact_fraction(), e.continuous_fraction()),
            (0.0, 0.0, 1.0)
        );
        assert_eq!(e.dissipated_energy(), 0.0);
        // from `start` on: the episode entered before still classifies (continuous here), and
        // the energy stored before `start` is no dissipation
        let e = run(&states, 1e-5, 5e-4);
        assert_eq!(e.continuous_fraction(), 1.0);
        assert_eq!(e.dissipated_energy(), 0.0);
        assert_eq!(e.recorded_time, e.contact_time);
    }
}
