//! The tick: [`Controller::step`] and its six stages, in the order they run.

use super::*;

impl<const K: usize> Controller<K> {
    /// One control tick. Never fails, never panics; the torque is finite and within the limit.
    ///
    /// The stages, in order (docs/design.md, section 6):
    /// 1. `estimate_hub`: the angle and rate from the counter;
    /// 2. `take_start`: a pending start moves Idle or Holding to Slewing;
    /// 3. `estimate_strain`: the strain and its rate;
    /// 4. `detect_faults`: any fault latches the Fault mode;
    /// 5. `advance`: the reference point, Slewing to Holding at the end;
    /// 6. `command`: the law, saturation, and the stall watch.
    #[inline(always)] // the call is to `step_in`, as the board's is
    pub fn step(&mut self, raw: &RawMeasurement) -> TorqueCommand {
        self.step_in::<ALL_LAWS>(raw)
    }

    /// [`Controller::step`] in a build that holds the laws `LAWS` only ([`LawSet`]; the law
    /// was built in it, `ControlLaw::try_build_in`): the board's tick, with no other law's
    /// arm in its dispatch.
    pub fn step_in<const LAWS: LawSet>(&mut self, raw: &RawMeasurement) -> TorqueCommand {
        self.st.uptime = self.st.uptime.wrapping_add(1);
        let hub = self.estimate_hub(raw);
        let mut faults = hub.faults;
        faults.insert(self.take_start(hub.theta));
        let (strain, strain_rate) = self.estimate_strain(raw.strain_root_code);
        let x = Estimate {
            theta: hub.theta,
            omega: hub.omega,
            strain,
            strain_rate,
        };
        self.st.theta = x.theta;
        self.st.strain = strain;
        faults.insert(self.detect_faults(raw, &x));
        if !faults.is_empty() {
            self.st.faults.insert(faults);
            let hard = FaultFlags(faults.0 & !GAUGE_FAULTS.0);
            if hard.is_empty() && matches!(self.st.mode, Mode::Slewing | Mode::Holding) {
                // A failed gauge (or a reading past the trip or at a rail, which a gauge
                // read at three times its gain gives as readily as a bent beam) does not
                // cut the torque under a moving hub, which would coast on: the move and
                // the hold go on without the gauge (see `GAUGE_FAULTS`).
                self.st.braking |= self.cfg.brake.takes_gauge_loss;
            } else {
                self.st.mode = Mode::Fault;
            }
        }
        let reference = self.advance(x.theta);
        let torque_nm = self.command::<LAWS>(&x, reference.as_ref(), hub.delta);
        TorqueCommand {
            torque_nm,
            mode: self.st.mode,
            faults: self.st.faults,
            theta_rad: x.theta,
            theta_ref_rad: reference.map_or(x.theta, |r| r.pos),
            strain,
        }
    }

    /// Stage 1: extends the counter, converts it to the hub angle and filters the rate. Flags
    /// an encoder jump (more counts in one tick than the hub can turn). Runs every tick, in
    /// every mode, before anything else: the start check needs the angle.
    #[inline(always)]
    fn estimate_hub(&mut self, raw: &RawMeasurement) -> Hub {
        let (cfg, st) = (&self.cfg, &mut self.st);
        let s = &cfg.settings;
        let mut faults = FaultFlags::default();
        let (count, delta) = st.counter.update_in(raw.encoder_raw, cfg.counter_width);
        // `delta` is a sign-extended difference of a counter of at most 32 bits, so it fits
        // an i32: compared in 32 bits, not in pairs of registers as an i64 is on the
        // Cortex-M4, and converted to f32 by one FPU instruction (an i64's is a call).
        let delta = delta as i32;
        if delta.unsigned_abs() > cfg.max_counts_per_tick {
            faults.insert(FaultFlags::ENCODER_JUMP);
        }
        let theta = angle_rad(
            count,
            s.theta_home_rad,
            cfg.rad_per_count,
            cfg.rad_per_count_fixed,
        );
        let omega = cfg
            .velocity_lpf
            .process(&mut st.omega, delta as f32 * cfg.rad_per_count / s.ts_s);
        Hub {
            theta,
            omega,
            delta,
            faults,
        }
    }

    /// Stage 2: acts on a start armed by [`start_move`](Self::start_move). With the hub at
    /// the move's start (within the tolerance), the strain offset averaged while idle is
    /// frozen and the mode becomes Slewing; otherwise the start is refused with
    /// [`FaultFlags::START_MISMATCH`]. Runs before the strain is estimated, so the move's
    /// first tick already uses the frozen offset; ignored in the Fault mode.
    #[inline(always)]
    fn take_start(&mut self, theta: f32) -> FaultFlags {
        let (cfg, st) = (&self.cfg, &mut self.st);
        let mut faults = FaultFlags::default();
        // A start is armed only outside the Fault mode (`start_move` refuses there) and this
        // stage, the first after the command, takes it before any fault of this tick can
        // latch: no mode check is needed.
        if st.start_pending {
            st.start_pending = false;
            // A brake starts where the hub is (see `start_brake`); a move where its plan does.
            let offset = if st.brake_pending {
                theta - cfg.spline.start()
            } else {
                0.0
            };
            if libm::fabsf(theta - offset - cfg.spline.start()) > cfg.settings.start_tolerance_rad {
                faults.insert(FaultFlags::START_MISMATCH);
            } else {
                if st.mode == Mode::Idle && st.zero_n > 0 {
                    st.offset_code = st.zero_mean;
                }
                st.mode = Mode::Slewing;
                st.ticks = 0;
                st.segment = 0;
                st.last_acc = 0.0;
                st.last_strain = None;
                st.strain_rate = 0.0;
                st.braking = st.brake_pending;
                st.ref_offset = offset;
                st.range.0 += offset;
            }
        }
        faults
    }

    /// Stage 3: the root strain with the offset removed, and its filtered rate (zero on the
    /// first tick of a move). While idle with the hub at rest, the code is added to the
    /// offset average.
    #[inline(always)]
    fn estimate_strain(&mut self, code: i32) -> (f32, f32) {
        let (cfg, st) = (&self.cfg, &mut self.st);
        // Only while the hub is at rest: a hub turned, pushed or coasting bends the beam,
        // and that strain is not the bridge's offset.
        if st.mode == Mode::Idle
            && st.zero_n < MAX_ZERO_SAMPLES
            && libm::fabsf(st.omega) < REST_RAD_S
        {
            st.zero_sum += code as i64;
            st.zero_n += 1;
        }
        let strain = (code as f32 - st.offset_code) * cfg.strain_per_code;
        let strain_rate = match st.last_strain {
            Some(prev) => cfg
                .strain_rate_lpf
                .process(&mut st.strain_rate, (strain - prev) / cfg.settings.ts_s),
            None => 0.0,
        };
        st.last_strain = Some(strain);
        st.same_code_ticks = if code == st.last_code {
            st.same_code_ticks.saturating_add(1)
        } else {
            0
        };
        st.last_code = code;
        (strain, strain_rate)
    }

    /// Stage 4: the faults of this tick's readings and estimate: an ADC at a rail, strain
    /// over the limit, the amplifier's fault line, a driver failure, a non-finite value.
    /// Pure: the caller latches what it returns.
    #[inline(always)]
    pub(super) fn detect_faults(&self, raw: &RawMeasurement, x: &Estimate) -> FaultFlags {
        let s = &self.cfg.settings;
        let mut faults = FaultFlags::default();
        let code = raw.strain_root_code;
        if code <= self.cfg.rails.0 || code >= self.cfg.rails.1 {
            faults.insert(FaultFlags::ADC_RAIL);
        }
        if libm::fabsf(x.strain) > s.max_strain {
            faults.insert(FaultFlags::OVER_STRAIN);
        }
        // `same_code_ticks` counts the repeats, so the code has been read once more.
        if self.st.same_code_ticks >= self.cfg.frozen_code_ticks {
            faults.insert(FaultFlags::GAUGE);
        }
        if raw.amp_fault {
            faults.insert(FaultFlags::AMP_FAULT);
        }
        if raw.driver_fault {
            faults.insert(FaultFlags::DRIVER);
        }
        // The angle is finite by construction (a validated home plus an integer count, below
        // 2^63, times a validated step: `angle_rad`), so it is not tested here; under torque
        // the range check in `advance` would catch it all the same.
        // `v - v` is 0 for a finite `v` and NaN for an infinite or NaN one, so the sum is 0
        // exactly when all three are finite: three subtractions and one comparison, where
        // `is_finite` is a masked compare and a branch each (10 instructions a tick).
        #[allow(clippy::eq_op)]
        let zero = (x.omega - x.omega) + (x.strain - x.strain) + (x.strain_rate - x.strain_rate);
        if zero != 0.0 {
            faults.insert(FaultFlags::NON_FINITE);
        }
        faults
    }

    /// Stage 5: while Slewing or Holding, the reference point of this tick; the move's
    /// clock advances, and Slewing becomes Holding once the move's time is up. `None` in the
    /// Idle and Fault modes (no torque), and when the hub has left the move's range
    /// (`st.range`, set when the move was armed), which latches
    /// [`FaultFlags::OUT_OF_RANGE`]: checked here, under torque only (an idle hub turned by
    /// hand is no fault), where the mode is known already.
    #[inline(always)]
    fn advance(&mut self, theta: f32) -> Option<RefPoint> {
        let (cfg, st) = (&self.cfg, &mut self.st);
        if !matches!(st.mode, Mode::Slewing | Mode::Holding) {
            return None;
        }
        // `!(a <= b)`: a NaN angle fails it too (NON_FINITE has latched already then).
        let (centre, half) = st.range;
        if !(libm::fabsf(theta - centre) <= half) {
            st.faults.insert(FaultFlags::OUT_OF_RANGE);
            st.mode = Mode::Fault;
            return None;
        }
        let t = st.ticks as f32 * cfg.settings.ts_s;
        let mut reference = cfg.spline.eval_from(&mut st.segment, t);
        reference.pos += st.ref_offset;
        if st.mode == Mode::Slewing {
            if t >= cfg.spline.duration_s() {
                st.mode = Mode::Holding;
            } else {
                // For a law with an observer (those that take a gauge's loss), the
                // acceleration the torque is held at until the next tick: the reference's
                // over the tick, not at its start (`held_acceleration`). The other laws are
                // given the latter.
                let acc = reference.acc;
                if cfg.brake.takes_gauge_loss {
                    reference.acc = crate::spline::held_acceleration(acc, st.last_acc);
                }
                st.last_acc = acc;
                st.ticks += 1;
            }
        }
        Some(reference)
    }

    /// Stage 6: the law's torque at `reference` (zero without one), a non-finite torque
    /// latched as a fault, saturation at the limit, and the stall watch: no encoder count
    /// (`delta` 0) for [`STALL_TICKS`] with the reference moving, under at least
    /// [`STALL_TORQUE_FRACTION`] of the limit or behind a reference that moves two counts a
    /// tick, latches [`FaultFlags::ENCODER_STUCK`]. Before the law, the drive's own law takes
    /// a weak law's hold over ([`HOLD_HANDOVER_RAD`]); after it, the observer laws' sensor
    /// monitor runs. Returns the torque to apply.
    #[inline(always)]
    fn command<const LAWS: LawSet>(
        &mut self,
        x: &Estimate,
        reference: Option<&RefPoint>,
        delta: i32,
    ) -> f32 {
        let (cfg, st) = (&self.cfg, &mut self.st);
        let mut torque = 0.0;
        if let Some(r) = reference {
            // The hold of a law with no integral action is the drive's once the law has
            // brought the hub to its target (see `HOLD_HANDOVER_RAD`).
            if st.mode == Mode::Holding
                && !st.braking
                && cfg.brake.takes_hold
                && libm::fabsf(x.theta - r.pos) < HOLD_HANDOVER_RAD
                && libm::fabsf(x.omega) < REST_RAD_S
            {
                st.braking = true;
            }
            torque = if st.braking {
                cfg.brake.torque_nm(x, r)
            } else {
                // Without a gauge, the laws that read it run on a beam read as straight
                // (a product, not a branch: one path through the law).
                // A gauge fault latched: the law runs only if it was latched under torque
                // (elsewhere it latched the Fault mode).
                let gauge = if st.faults.0 & GAUGE_FAULTS.0 != 0 {
                    0.0
                } else {
                    1.0
                };
                let x = Estimate {
                    strain: x.strain * gauge,
                    strain_rate: x.strain_rate * gauge,
                    ..*x
                };
                cfg.law
                    .torque_nm_in::<LAWS>(&x, r, &mut st.law_state, cfg.settings.ts_s)
            };
            if !torque.is_finite() {
                st.faults.insert(FaultFlags::NON_FINITE);
                st.mode = Mode::Fault;
                torque = 0.0;
            }
            #[cfg(feature = "observer")]
            if !st.braking {
                let seen = watch_sensors(&st.law_state, &cfg.settings, st.still_ticks, r);
                // A failed gauge, or a loop that rang through it: the rest of the move and
                // the hold on the drive's own law, which reads the encoder alone; no move is
                // taken until the fault is cleared.
                const SOFT: u16 = FaultFlags::GAUGE.0 | FaultFlags::RINGING.0;
                let soft = FaultFlags(seen.0 & SOFT);
                if !soft.is_empty() {
                    st.faults.insert(soft);
                    st.braking = true;
                }
                let hard = FaultFlags(seen.0 & !SOFT);
                if !hard.is_empty() {
                    st.faults.insert(hard);
                    st.mode = Mode::Fault;
                    torque = 0.0;
                }
            }
        }
        #[cfg(feature = "observer")]
        {
            st.still_ticks = if delta == 0 {
                st.still_ticks.saturating_add(1)
            } else {
                0
            };
        }
        let limit = cfg.settings.torque_limit_nm;
        // Comparisons, not `clamp` (its min <= max assertion would put a panic on the tick
        // path) nor `max`/`min` (library calls on the Cortex-M4F, which has no VMAXNM). The
        // torque is finite here and the limit was validated positive.
        let mut torque = if torque > limit {
            limit
        } else if torque < -limit {
            -limit
        } else {
            torque
        };
        // Only while the reference moves: a hub held still against a load (a tilted rig, a
        // cable, an end stop) by a law that is told to hold it reads no counts under torque
        // for as long as it is held, and that is right; a hub that the reference moves on
        // and the encoder does not see move is a stuck encoder or a blocked hub.
        // Pushing blind (a fifth of the limit), or following a reference that moves two
        // counts a tick or more (a law that pushes softly, the paper's SMC, lets the hub run
        // on for seconds on a frozen count otherwise).
        if st.mode != Mode::Fault
            && delta == 0
            && reference.is_some_and(|r| {
                r.vel != 0.0
                    && (libm::fabsf(torque) >= cfg.stall_torque_nm
                        || libm::fabsf(r.vel) >= cfg.stall_speed_rad_s)
            })
        {
            st.stall_ticks = st.stall_ticks.saturating_add(1);
        } else {
            st.stall_ticks = 0;
        }
        if st.stall_ticks >= STALL_TICKS {
            st.faults.insert(FaultFlags::ENCODER_STUCK);
            st.mode = Mode::Fault;
            torque = 0.0;
        }
        torque
    }
}

/// The hub's estimate from the encoder, with the counter's change and any jump fault.
#[derive(Clone, Copy, Debug)]
struct Hub {
    theta: f32,
    omega: f32,
    delta: i32,
    faults: FaultFlags,
}

/// `sum / n` in `f32`, to within one step of `f32`, for `1 <= n <= 2^16`
/// ([`MAX_ZERO_SAMPLES`]): the whole part of the mean (a code, so at most 2^31 and one
/// conversion) plus the remainder's fraction. The division runs on 16-bit digits, each step
/// within the Cortex-M4's 32-bit divide instruction: no double precision, and no 64-bit
/// division routine (0.9 KB of flash for this one use).
pub(super) fn mean_code(sum: i64, n: u32) -> f32 {
    let n = n.clamp(1, MAX_ZERO_SAMPLES);
    let magnitude = sum.unsigned_abs();
    let (mut whole, mut rest) = (0u64, 0u32);
    for digit in (0..4).rev() {
        // rest < n <= 2^16, so this fits 32 bits.
        let cur = (rest << 16) | ((magnitude >> (16 * digit)) & 0xffff) as u32;
        whole |= u64::from(cur / n) << (16 * digit);
        rest = cur % n;
    }
    let mean = whole as u32 as f32 + rest as f32 / n as f32;
    if sum < 0 {
        -mean
    } else {
        mean
    }
}
