"""Analysis of bouncing sounds: find the ticks in a recording and measure them.

The measurements are the perceptual parameters of PHYSICS.md section 7 (thesis
Chapter 5 and section 3.1): per tick the onset, the bounce time since the
previous tick, the restitution ``e_n = t_n / t_(n-1)`` and the impact speed
``v_n = g t_n / 2`` that follow from the bounce times, the tick's energy and
peak, its spectral centroid and spread, and its decay time.

Restitution from bounce times
-----------------------------
``e_n = t_n / t_(n-1)`` is the thesis' definition (section 3.1) and what a listener
hears, but it is not exactly the physical restitution of an impact (rebound over impact
speed). A bounce time holds the contact too: ``t_n = tau_n + 2 e_n v_n / g`` (PHYSICS.md
section 5), so ``t_n / t_(n-1) = (tau_n + e_n a) / (tau_(n-1) + a)`` with ``a = 2 v_n / g``
and ``t_n / t_(n-1) / e_n - 1 = (tau_n / e_n - tau_(n-1)) / t_(n-1)``: of the order of the
contact time over the bounce time. That is below 1e-3 while bounces last 100 times a
contact (the first bounces of hard balls: 20-500 us contacts, 50-500 ms bounces), and
tens of per cent for the last bounces of a ball coming to rest, whose flights are as
short as their contacts. ``v_n = g t_n / 2`` likewise holds the contact: it overestimates
the impact speed by ``g tau_(n-1) / 2``.

Tick detection
--------------
A bouncing ball's ticks come closer and closer (the last ones a few ms apart)
and each rings on under the next ones, so on the raw level the later ticks are
small bumps on the earlier tails. All the ticks of one recording are the
response of one resonator (plate, room, microphone) to short contact forces, so
the detector first takes the resonator out:

1. **Whitening.** A linear predictor of order ``p`` (default 20 ms of samples,
   enough poles for a few hundred modes and for the early reflections of a room; step
   7 replaces it by the resonator's own where it leaves the first tick ringing) is
   fitted to the whole signal (autocorrelation method, Levinson recursion)
   and the prediction error ``r = A(z) x`` is formed, the recording taken as silent
   before its first sample. The ringing of a tick is predictable from its own past
   and largely cancels; what is left is close to the excitation, one short burst per
   contact, in whitened noise. This is the inverse filter of linear-prediction
   analysis (Makhoul 1975, Proc. IEEE 63, 561), used as the whitening step of an
   onset detector (Stowell and Plumbley 2007, ICMC). Clipped samples (below) are
   interpolated first.
2. **Detection function.** The energy of ``r`` over frames starting every
   ``hop`` seconds (default 0.25 ms), each at least 12 samples long (at low
   rates the frames overlap, so that a frame of noise is never a sum of only a
   few squares, whose scatter would pass for a tick).
3. **Adaptive threshold.** A frame is a candidate when it is a local maximum
   and clears all of: ``threshold_db`` above the local background (running
   median over ``background`` seconds, robust to the ticks, which are sparse
   in time); ``rise_db`` above a memory of the earlier frames (from two frames
   back) that fades by ``release`` dB per ms, which rejects what the whitening
   leaves of a tick in its first milliseconds; and the floor
   ``dynamic_range_db`` (default 60 dB; step 7 sets its own) below the strongest frame.
   Taken in time order, a
   candidate more than ``max_drop_db`` (20 dB) weaker than the previous tick
   is not a bounce (a tick's energy goes as the impact speed squared: that
   would be a restitution below ``e_min = 10^(-max_drop_db / 20) = 0.1``) but a
   remainder of the earlier ticks. Candidates closer than ``min_separation``
   (1 ms) form one tick, whose onset is the first candidate's. The first
   candidate is the first tick. The second is chosen by the physics of a bounce
   series: every bounce time lies between ``e_min`` and ``BOUNCE_GROWTH`` (1.5)
   times the one before (the ball loses energy at every impact, so its flights
   shrink; 1.5 leaves room for the contact time, which grows as the ball slows,
   and for a tick missed in between), and the second tick is the one that starts
   the longest such series from the first (dynamic programming over the first 64
   candidates; of equally long series, the one whose second tick comes first).
   The candidates before it are the first tick's own response: the end of a long
   contact (a second burst, as strong as the first for a symmetric force pulse,
   1.5-5 ms later for a rubber ball) and the room's early reflections (delayed,
   filtered copies of the tick, weaker than it). The ticks of that series standing
   ``ANCHOR_DB`` (20 dB) or more above their threshold are sure.
4. **Onset refinement.** From the largest ``|r|`` near the candidate (its frame and a
   hop either side), walk back through the samples at or above a level, bridging gaps
   up to 0.25 ms (the zero crossings inside a burst), to the earliest; the onset is
   the crossing of the level just before it, linearly interpolated between the two
   samples. The level is ``onset_fraction`` (0.1) of the burst's largest ``|r|``,
   but at least 4 standard deviations of the whitened background, so that noise
   cannot continue the walk (a Gaussian sample exceeds 4 sigma with probability
   6e-5). A burst preceded by a run of 3 or more samples alternating in sign and
   growing towards it is a tick recorded through a linear-phase anti-aliasing
   filter: its whitened burst is a sampled sinc whose magnitude falls only as
   ``1/k`` before its centre (the level crossing would land up to 3.6 sample periods
   early), and the onset is that centre, ``m + f`` with ``f / (1 - f)`` the ratio of
   the two central samples ``r[m+1] / r[m]`` (for ``A sinc(t - m - f)``). A candidate
   whose onset walks back to within ``min_separation`` of the previous tick's
   belongs to it; one that walks back to the first sample is the recording's cut,
   not a contact.
5. **Deflation.** Whitening leaves each tick's excitation smeared over tens of
   milliseconds (the inverse of an all-pole fit to a resonator with hundreds of
   modes is not its exact inverse), and late, weak ticks drown in the smear of the
   earlier, strong ones. But every tick goes through the same path (impact point,
   plate, room, pickup) and differs from the others only by its contact force:
   in the whitened signal a later tick is the first tick's response ``T``
   (from its onset to the second tick of step 3, with its contact's end and its
   reflections, ended where it sinks into the noise) through a short filter (lags
   -0.06 to +0.17 ms: an onset error, a longer pulse). So the ticks after the
   first are found one by one on ``q = r - (what the earlier ticks explain)``: the
   first candidate of ``q`` after the previous onset that clears the rules of step
   3 (against the median of the past 20 ms of ``q``, never below the whitened
   noise floor) and carries more energy than was taken out of its frame and over
   the 1 ms from the frame before it (else it is a remainder of the earlier
   ticks: a model a fraction of a sample off leaves its remainder spread around a
   burst); its onset by step 4 on ``q``. Two rules of the bounce series reject
   what is left of the previous tick's own response (the end of a contact that
   lasted longer than the first tick's, a reflection the model left over): a
   bounce shorter than ``e_min`` times the previous one, and a candidate whose
   whitened energy is more than ``MAX_EXCESS_DB`` (6 dB) above what its bounce
   time allows, ``(t_n / t_(n-1))^2`` times the previous tick's (the impact speed
   goes as the flight time and a tick's energy as the speed squared; 6 dB covers a
   remainder of the earlier ticks as large as the tick, which the remainder test
   lets through, and a background 10 dB under the threshold). Neither applies
   after a doubtful tick (``strength`` below 6 dB), which may be a remainder
   itself. No sure tick of step 3 is passed over: where the search would skip one
   (a model that fits the earlier ticks badly, as clipped ones), it is taken.
   Then the filter ``h`` is fitted by least squares to ``q`` from the onset to the
   next candidate, and ``h * T`` is taken out of ``q``. If that removes the next
   candidate (a remainder of this tick), the fit is redone over the longer
   stretch. ``deflate=False`` keeps the ticks of step 3.
6. **Bounce order.** Taken in time order, a tick sooner than ``e_min`` times the
   last bounce time after the last tick is dropped (a doubtful last tick gives
   way to a stronger one just after it). Where a bounce time is more than 1.5
   times the previous one, a weaker tick of the short bounce split a bounce in two
   and goes when that restores the order (the one that ends it, the one that
   starts it, or a run of the last few ticks that are not sure); else the new
   tick is dropped if doubtful (a late remainder) and kept if not (a missed tick
   or a second drop). Last, a tick that is not sure is dropped when the bounce
   across it continues the series' restitution within ``RESTITUTION_STEP`` (25 %)
   and the two bounces it makes do not: a restitution changes slowly along a
   series, with the impact speed (the presets' steepest step is 18 %).
7. **The resonator's search.** On a lightly damped resonator with many modes (a thin
   steel sheet: hundreds of modes ringing for seconds) the 20 ms predictor leaves the
   first tick ringing above the floor of the dynamic range over the whole first bounce
   (the median frame energy of its second half), beyond the span over which step 5
   knows that tick's response, and the later ticks stay under what is left. Then the
   ringing itself is cancelled. The free ringing of the first bounce (from
   ``CLEAN_GUARD``, 2 ms, after the first onset to the second tick) is a sum of
   decaying modes, which a predictor of at least twice their number annihilates. It is
   fitted by the covariance method (least squares over the stretch: a window would bias
   the poles of the slowly decaying modes), of the order of least description length
   ``N ln(E_m / N) + m ln N`` (Rissanen 1983, Ann. Stat. 11, 416; ``E_m`` the
   prediction error over the stretch, counted down to 120 dB of prediction gain) whose
   all-pole model is stable, from 20 ms up to a third of the stretch and 4096; in noise
   the error reaches the noise, and the order stops there. The noise, which no order
   predicts, is then added to the normal equations as white noise (a ridge): else a band
   that the ringing leaves empty (above its modes, under an anti-aliasing filter) would
   be lifted far over the noise, and the ticks' onsets drown in it. Whitened by it, a
   tick's response is its force through a filter of that order: it ends. Steps 2-6 run
   again on that signal, with these rules:

   * the local background of step 3 is the median over four predictor orders (a
     tick's whitened response lasts one);
   * the templates are the first tick's whitened response and those of the next sure
     ticks (at most three in all) whose response ends before the next bounce begins:
     the series' soonest (its restitution changes by ``RESTITUTION_STEP`` at most), or
     for the second tick the next tick the first search found (the ticks of a series
     only weaken: one it missed comes later). Their sub-sample onsets differ, and a
     tick's sampled response near the Nyquist frequency depends on where its onset
     falls between two samples, which no short filter of one template reproduces;
     filters on two or three templates do;
   * each later tick is modelled through a filter on each template, lags -0.06 to
     +0.5 ms (contacts up to 0.5 ms longer than the first), -0.06 to +0.17 ms, or -1 to
     +2 samples, over all templates or the first ones: of the choices with two samples
     of the fit window per unknown, the one of least description length;
   * a candidate must carry more energy than the earlier ticks' models are expected to
     leave in its frames (their relative error in their fit windows, raised 10 dB), not
     than all they took out. That error is counted up to the soonest next bounce the series
     allows (below): beyond it, a window may hold later ticks that no model explains yet,
     whose energy is no error of this one (on the 6 mm board of ``tests/test_roundtrip.py``
     a window that ran past ticks 8 and 9 put tick 7's relative error at -8.8 dB, and
     raised 10 dB, all of its model was expected to be left);
   * once the next tick is found, a tick's model is fitted again, jointly with the next
     tick's (both ticks' filters on the templates, one choice of templates and lags for the
     two, of least description length over both ticks' unknowns), over the next tick's fit
     window; then the next tick's model alone again, with the new one taken out, and the
     earlier tick is timed again from its new model. Fitted up to where the next tick
     shows, a model rests on one bounce (1.1 to 2.6 ms for the board's last ticks) while
     its response goes on under the next tick; the next tick's window holds both;
   * a tick's fit window ends where the next tick shows, which its own response may
     hide: windows ending from the soonest bounce the series allows (``1 -
     RESTITUTION_STEP`` times the last restitution times the last bounce), each 10 %
     longer, up to the latest (``BOUNCE_GROWTH`` times instead), until one uncovers a
     tick at its end; the search for the next tick starts at that soonest bounce, not
     ``min_separation``;
   * the onset walk stays within a frame of the first frame above the threshold (the
     earlier ticks' remainders lie before), and alternating samples under the noise
     level are no filter's pre-ringing;
   * when no candidate clears these rules, one more tick of the series is tried by model
     order selection instead of an energy margin: the last tick's model, fitted alone or
     jointly with a new tick's (as in the joint refit above), over a window from the last
     tick's start to a last bounce past the latest next bounce the series allows, its model
     not taken out; the new tick put every :data:`HYPOTHESIS_STEP` (4) samples from the
     soonest next bounce the series allows (as the search: ``min_separation`` after a
     doubtful tick) to the latest (``BOUNCE_GROWTH`` times the last restitution times the
     last bounce). With the new tick, the description length ``N ln(E / N) + k ln N``
     (the filters' choice above: ``N`` the samples of the whitened signal in the window,
     ``E`` the residual energy there, ``k`` the filter taps, each fit of its own choice of
     templates and lags), plus ``2 ln M`` for its place among the ``M`` tried, must fall;
     the tick must also clear the floor (below) as any candidate (only the places where
     the residual does are tried: each costs a fit of every choice of templates and lags,
     and in a noisy recording the range spans tens of milliseconds), and it is not tried
     after a bounce longer than the one before (a tick missed in between, whose response
     no model holds, would be taken for it). Its onset comes from the timing against the
     template (below) and its ``strength`` is the fall of the description length per
     sample, in dB of residual energy. The criterion takes the residual for white noise of
     unknown variance ``E / N`` (Rissanen 1983). In a clean render that residual is the
     models' misfit (a slow contact's response through filters on the first ticks'
     templates), 100 dB and more over the rounding noise, and not white (on the 6 mm board
     around its ninth tick: lag-one autocorrelation 0.54 without the new tick, 0.68 with
     it): ``k ln N`` is then the price of a tap against the misfit it removes, not a code
     length. In recorded noise near the residual (white noise 80 to 90 dB under the 6 mm
     board's ticks) the test put a tick at the end of a slow contact, 0.4 ms after its
     start, until the floor rule was added; a place within the previous tick's filters'
     lags does not separate a new tick from a longer contact;
   * every tick after the first is then timed against the first tick's whitened response
     (the first template), not by its level crossing: a contact of one or two sample
     periods leaves a burst of two or three samples, whose crossing moves by up to a
     sample period with where the contact starts between two samples. The tick's model
     (its filters on the templates, fitted above: it holds no noise, and for one template
     its cross spectrum with it is ``H |T|^2``, of the filter's phase) is delayed behind
     the template where their cross-correlation with the phase transform peaks (each
     frequency's cross spectrum at unit magnitude, Knapp and Carter 1976, IEEE Trans.
     ASSP 24, 320: the delay whose linear phase best fits the filter's over the band; the
     plain cross-correlation is ruled by the band near the Nyquist frequency, where the
     whitened responses carry most of their energy, and has lobes two samples apart of
     nearly the same height: over the ticks' fit windows it took a wrong one for two of
     the steel sheet's nine), interpolated band-limited (its spectrum zero-padded
     ``DELAY_UPSAMPLING`` (16) times, a parabola through the peak), within the lags of the
     filters. The onset is the template's onset plus that delay. The template's own onset
     is its level crossing (step 4): the first tick is the strongest, the one whose
     crossing the noise cuts least, and its error (within a sample period for a contact
     shorter than one) is common to every onset this search times: it cancels in their
     bounce times. Against the first tick's, a longer symmetric contact force is a filter
     of zero phase about the two pulses' centres, as long as neither spectrum changes sign
     over the band (a half-sine's first zero lies at ``1.5 / tau``: above the Nyquist
     frequency for contacts shorter than 3 sample periods, 62.5 us at 48 kHz). Then the
     delay aligns their centres, and a tick's onset comes late by half its contact's
     growth, ``(tau_n - tau_1) / 2``. The contact time grows slowly along a series (as
     ``v^(-1/5)`` for a Hertz contact), so this bias changes little from one tick to the
     next and mostly cancels in bounce times: on the 1 mm steel sheet of
     ``tests/test_roundtrip.py`` (contacts 15 to 43 us) it is 1.5 to 13.7 us for ticks
     2-10, 1.5 to 1.7 us more from one tick to the next: at most 0.17 % of a bounce time
     and 0.06 % of ``e_n`` (the tenth). The onsets measured there follow it within 1.8 us;
     on the aluminium plate (contacts 40 to 60 us, 0.8 to 10.1 us of bias) within 0.4 us,
     and within 1.1 us over its first 21 ticks (contacts up to 84 us); its later ticks,
     whose contacts reach 0.13 ms, drift up to 23 us early of it (ticks 22-39), towards
     their starts, and the last ones found (40, 41, 43, 44 and 47: contacts 0.14 to 0.17
     ms, bounces of 0.8 ms and less) 5 to 210 us.
     Contacts of many sample periods (0.15 to 0.32 ms on the 6 mm board of the same test)
     have spectra that change sign in the band, and above their first zeros are the
     transients at the contacts' two ends; there the phase transform aligns the starts
     (measured, not a rule): onsets 2-6 come 1.6 to 3.9 us later than the first (whose
     level crossing is 87 us late), not the 16 to 86 us of their centres. When the search
     is kept (below), its onsets replace the first search's for the ticks they share too:
     one estimator for every bounce time. A tick's model, and its measurement window,
     start from its level crossing.
   * with the default ``dynamic_range_db`` there is no fixed floor under the strongest
     frame: the fixed 60 dB (:data:`DYNAMIC_RANGE_DB`) guards steps 1-6 against what the
     whitening leaves of the earlier ticks, which here their models and the remainder test
     account for. The floor is the whitened noise floor (per frame) raised by
     ``threshold_db``, as the local background's, and, as step 3's ``max_drop_db`` rule,
     ``e_min^2`` times the last tick's energy (20 dB under it: a bounce's tick goes as its
     impact speed squared; without it, on the steel sheet below, remainders of the earlier
     ticks pass for ticks in its first bounces, 0.3 to 3.3 dB over their thresholds),
     never under :data:`PREDICTION_FLOOR` (120 dB) of the strongest frame (rounding).
     Where the whitened noise lies within 60 dB plus ``threshold_db`` of the strongest
     frame, the background's threshold (never under the noise raised by ``threshold_db``)
     already stood over the fixed floor, and nothing is lower than before. A
     ``dynamic_range_db`` given holds here too, as asked.

   This search is kept when its predictor leaves the first tick at least
   ``RESONATOR_GAIN_DB`` (20 dB) less ringing and it finds the first search's ticks, from
   the first on (at least two), within ``AGREEMENT`` (40 us) of theirs (their level
   crossings): then it continues their series where the two part (where the first search
   has no more ticks, or its next one later). Not for a clipped recording, nor with
   ``lpc_order`` given or ``deflate=False``.

The onset is where the whitened excitation first reaches the level: the start
of contact to within a few samples. Measured on synthetic ticks with known
sub-sample onsets (``tests/test_analysis.py``, tails overlapping): for sums of
damped sinusoids started abruptly (the onset lies anywhere in the sample period
before the first non-zero sample), within 0.9 sample periods of it at every
rate from 22.05 to 96 kHz; for their exact response to half-sine contact forces
of 0.1 and 0.5 ms, within 0.4 sample periods of the first touch. Recorded through
an anti-aliasing filter (scipy's ``resample_poly``: a Kaiser-windowed sinc), within
-1.3 to +0.6 sample periods at 8 to 96 kHz (the window makes the burst differ from
an ideal sinc): at most 74 us at 8 kHz, 57 us at 11.025 kHz, 81 us at 16 kHz. Where a
tick's modes lie above the Nyquist frequency of a low rate the filter removes them
and the tick is what is left below it; bounce times and ``e_n`` keep their accuracy
(within 0.3 % at 8 kHz). The first ten ticks keep their accuracy with white noise
down to 20 dB SNR, with early reflections of gains up to 0.7 at 2-25 ms, in a room
whose diffuse reverberation carries as much energy as the direct sound, and in that
room with 20 dB SNR. Weak ticks (``strength`` below about 5 dB) may be a few samples
late: the noise level then cuts the beginning of the burst. On a lightly damped plate
with dense modes, step 7 finds ticks far under the ringing of the earlier ones: on the
1 mm steel sheet of ``tests/test_roundtrip.py`` its ticks 4-10, 14.8 to 35.2 dB under the
ringing, stand 63 to 25 dB above what the earlier ticks leave in their first millisecond
(2.6 to -21 dB after steps 1-6). Timed against the first tick's template, the first ten
onsets come 2.1 to 16.6 us after the engine's (the first tick's level crossing, 2.1 us, plus
the bias of the contacts' growth, 0 to 13.7 us, plus at most 1.8 us), their bounce times
0.1 to 2.7 us long, and ``e_n`` within 0.12 % (0.11 %, the ninth; the tenth, over a bounce
of 0.97 ms, 0.07 %). By
their level crossings, whose place moves by up to a sample period with where a contact of
one or two sample periods starts between two samples, the onsets came 1.2 to 19.9 us late,
the bounce times -9.0 to +13.3 us off, and the tenth ``e_n`` 1.46 %. Ticks more than
``dynamic_range_db`` under the strongest in the whitened signal stay out of steps 1-6: on
the 6 mm board of the same test, the late, slow contacts (0.37 to 0.55 ms)
take the high frequencies out of ticks 7-9 and leave them 66 to 81 dB under the first tick
there, where the whitened noise of the clean render is 196 dB under it. Step 7's floor
(noise and last tick) lets ticks 7 and 8 in. Tick 8 clears
what the earlier models are expected to leave by little: in its second frame, -79.3 dB of
the strongest frame against -79.6 dB expected (the joint refits of each tick with the next
one, the error counted up to the soonest bounce; before them -73.7 dB was expected there,
tick 7's model fitted over a window that ran past ticks 8 and 9). Tick 9 (its own strongest
frame -81.1 dB, after a 1.1 ms bounce) clears no threshold: with tick 8 still in, its first
frame stands under the fading memory of tick 8's burst (-79.5 against -74.3 dB:
``rise_db``), so tick 8's fit window runs past it, and tick 8's model takes 4.4 dB out of
that frame; what the earlier models really leave there is only 3 to 8 dB under tick 9 (tick
8's -84.3 dB, tick 7's -89.1 dB, measured with the ticks rendered alone): less than the
:data:`REMAINDER_MARGIN_DB` by which their expected remainder is raised. The test of one
more tick by description length finds it: over the 145 samples from tick 8's start, tried
from 1 ms (``min_separation``: tick 8, 3.8 dB, is doubtful) to 1.73 ms after tick 8, the
description length falls by 0.86 dB of residual per sample with it; a tenth, tried after
it, would raise it by 4.0 dB per sample. Timed against the template, onsets 1-9 come 86.8
to 91.1 us late (the first tick's level crossing, 86.8 us: the start of its slow burst is
taken for a filter's pre-ringing, step 4) and ``e_n`` within 0.16 % (``e_9``; the others
within 0.042 %). On the steel sheet the same test finds tick 11 (18.4 us late), after the
ten above; on the aluminium plate it tries one more after the last tick found and rejects
it; the other presets do not keep step 7. With white noise 80 to 150 dB under the board's
ticks (peak; 6 seeds a level) it found tick 9 in 4 more of the 72 runs and a true tick for
a false one in one, and changed nothing else (the false ticks at 120 to 125 dB, where tick
8 is lost, were there before).
Noise limits step 7 through its predictor: on a synthetic plate of 300 modes
(``tests/test_analysis.py``: identical ticks, impulses between samples) it finds all 11
ticks (8 without it), 4.4 to 7.2 us early (the first tick's level crossing: 7.1 us) and
``e_n`` within 0.1 % (by level crossings: -12.5 to +6.8 us, 1.2 %), also with white noise
60 dB under the ticks, and at 40 dB its predictor no longer gains 20 dB on the 20 ms one.
On the steel sheet, white noise even 120 dB under the ticks leaves no stable predictor among the
orders that cancel its modes (900 to 1480: fitted to noisy ringing, the extra zeros of the
least-squares predictor fall outside the unit circle); the stable one of order 344 gains
only 18 dB, and the first search's three ticks stand.

Tick measurements
-----------------
Every tick is measured over the same window: ``window`` seconds (default 20 ms) from
2 samples before its onset (its level crossing, for a tick timed by step 7; less where the
recording ends). The signal there holds the
tails of the earlier ticks and, when the next bounce is shorter than the window, the
next ticks; the tick's own sound ``y`` is made from its own excitation through the
whitening predictor's all-pole model ``1/A`` (the resonator; for a tick of step 7, its
predictor's, whose stability step 7 ensures): with the deflation, the
tick's model ``h * T`` plus what no tick explains (``q``, the noise) over the window;
without it, ``r`` from the tick's onset to the next tick's, its free ringing after. So a
series of identical ticks gives the same centroid, spread and decay time for every
tick, and energies and peaks in the ratio of the ticks' amplitudes squared and
amplitudes, whatever the bounce times. ``subtract_tails=False`` measures the
recording itself over the window instead. On ``y``:

* ``energy = sum(y^2) / samplerate``, signal units^2 s;
* ``peak = max |y|``, signal units;
* ``centroid`` and ``spread``: mean and standard deviation of frequency
  weighted by the power spectrum ``|Y(f)|^2`` (Hz), with ``y`` tapered by the
  falling half of a Hann window (the onset is kept, the cut at the window's
  end is smoothed);
* ``decay_time``: the time for the amplitude envelope to fall to ``1/e`` of its
  peak, s: ``-1/slope`` of a least-squares line through the log of the
  envelope (root of ``y^2`` smoothed by a Hann window of ``decay_smoothing``
  seconds) from its peak to the end of the window, or to where it comes within
  10 dB of the noise floor. ``None`` when that span is shorter than the
  smoothing, or when the fitted envelope falls by less than 0.1 neper (0.87 dB)
  over it (a decay time over ten times the span: lengthen ``window``).

The window holds the noise too: at low SNR the energy of weak ticks is
raised by ``noise_floor^2 * window`` and their centroid and spread move
towards the noise's.

The noise floor is the RMS of the 10 ms frames within 3 dB of the quietest one
(frames of noise alone scatter far less than that; frames with a tick or a
tail stand above).

Clipping
--------
When ``clip_samples`` or more samples of a channel sit at exactly its largest (or
smallest) value, the channel is taken as clipped there: :attr:`Analysis.clipped` is
true and :attr:`Analysis.warnings` says so (``on_clipping="raise"`` raises instead).
A clipped run is a kink the resonator cannot make, which the whitening turns into
bursts that pass for ticks; so the clipped samples are treated as missing and
interpolated by least squares under a linear predictor fitted to the unclipped
ringing (Janssen, Veldhuis and Vries 1986, IEEE Trans. ASSP 34, 317), each kept at
least at its clipped magnitude, before the ticks are sought. The loudest ticks'
peaks, energies and spectra stay unreliable, and their onsets may be off too. Runs of a
millisecond or more (the low thud of a rubber ball clipped 6 dB or more) cannot be
restored, and false ticks may remain.
"""

from __future__ import annotations

import csv
import io
import math
import os
import tempfile
from dataclasses import asdict, dataclass, fields

import numpy as np

from synth import checks
from synth.errors import ParameterError, SynthError

#: Level of the onset walk relative to the whitened background, standard deviations.
ONSET_NOISE_SIGMAS = 4.0
#: Longest gap bridged by the onset walk inside one burst, s.
ONSET_GAP = 0.00025
#: Samples alternating in sign and growing towards a burst, at least, that are taken for
#: an anti-aliasing filter's pre-ringing rather than the start of the contact (ending on
#: a sample at least a quarter of the burst's largest).
PRE_RINGING_RUN = 3
#: Fewest samples summed in a frame of the detection function.
MIN_FRAME = 12
#: Samples kept before the refined onset in a tick's window.
WINDOW_GUARD = 2
#: The decay fit stops where the envelope comes within this of the noise floor, dB.
DECAY_NOISE_MARGIN_DB = 10.0
#: Least fall of the fitted envelope over the fitted span, nepers (0.87 dB): a
#: smaller one cannot be told from noise and the other ticks' tails.
DECAY_MIN_FALL = 0.1
#: Lags of the FIR filter that shapes the first tick's whitened response into a later
#: tick's, s: before (onset error) and after (a longer contact than the first).
DEFLATION_PRE = 0.00006
DEFLATION_POST = 0.00017
#: In the resonator's search (step 7), the longest lag after, s: a contact up to 0.5 ms
#: longer than the first tick's (a slow ball's on a soft board).
RESONATOR_POST = 0.0005
#: In the resonator's search, least samples of the fit window per unknown filter tap.
FIT_SAMPLES_PER_TAP = 2
#: In the resonator's search, ticks whose whitened response is taken whole as a template,
#: at most: the first tick's and the next sure ones alone over their whole response (their
#: sub-sample onsets differ; two or three such span the sampled responses of the others).
MAX_TEMPLATES = 3
#: A candidate must carry at least this much more energy than what the deflation took
#: out of its frame, dB (else it is a remainder of an earlier tick).
DEFLATION_KAPPA_DB = 0.0
#: In the resonator's search, what a tick's model leaves outside its fit window is expected
#: at its relative error in the window raised by this, dB (at most all of it).
REMAINDER_MARGIN_DB = 10.0
#: A candidate must also carry more energy than was taken out over the frames spanning
#: this from the frame before its own, s.
REMAINDER_SPAN = 0.001
#: The template ends at its last frame this far above the whitened noise floor, dB.
TEMPLATE_NOISE_DB = 6.0
#: In the resonator's search, the template ends where it sinks under the noise or this far
#: under the floor of the dynamic range, dB (its whitened response ends: beyond, what it
#: leaves raises no frame to the floor).
TEMPLATE_FLOOR_DB = 10.0
#: In the resonator's search, the cross-correlation that times a tick against the first
#: tick's template is interpolated on a grid this many times finer than the sample period
#: (band-limited), then by a parabola through its peak (off by well under 1e-3 sample
#: periods at that spacing for a main lobe about a sample period wide).
DELAY_UPSAMPLING = 16
#: In the resonator's search, the spacing of the places where one more tick of the series
#: is tried when no candidate clears the rules, samples: the span of the shortest filters'
#: lags (-1 to +2 samples), so that an onset lies within those lags of one of the places.
HYPOTHESIS_STEP = 4
#: Fits of a tick's filter at most, each over a longer stretch.
DEFLATION_REFITS = 3
#: A bounce time more than this many times the previous one breaks a bounce series
#: (a restitution above 1.5).
BOUNCE_GROWTH = 1.5
#: Candidates over which the longest bounce series from the first tick is sought when
#: choosing the second tick.
SERIES_HORIZON = 64
#: A candidate more than this above the energy its bounce time allows, ``(t_n / t_(n-1))^2``
#: times the last tick's (the impact speed goes as the flight time), is not a bounce,
#: dB: 3 dB for a remainder of the earlier ticks as large as the tick itself (the most
#: the deflation's remainder test lets through), 0.4 dB for a background 10 dB under
#: the threshold, rounded up.
MAX_EXCESS_DB = 6.0
#: Ticks at least this far above their threshold are sure, dB: no bounce-order rule
#: drops them for a weaker one, and the deflation passes over none of step 3's series
#: (100 times the threshold; the remainders and reflections met so far reached 11 dB).
ANCHOR_DB = 20.0
#: Largest relative change of the restitution from one bounce to the next in a series:
#: the presets' steepest is 18 % (a steel ball on a 6 mm board, whose contact time
#: grows to a sizeable part of the bounce time).
RESTITUTION_STEP = 0.25
#: Ticks weaker than this (``strength``, dB) are doubtful.
DOUBTFUL_DB = 6.0
#: Highest order of the resonator's predictor (step 7): its cost grows as the cube.
MAX_ORDER = 4096
#: In the resonator's search, the local background of step 3 is the running median over
#: this many times the predictor's order (the length of a tick's whitened response), at
#: least ``background``.
BACKGROUND_SPAN = 4
#: The resonator's search (step 7) is kept when its predictor leaves at least this much
#: less of the first tick's ringing than the first search's, dB.
RESONATOR_GAIN_DB = 20.0
#: The resonator's search must find the first search's ticks within this, s (two sample
#: periods at 48 kHz), to continue their series.
AGREEMENT = 0.00004
#: Least prediction error energy of the resonator's predictor counted by its order
#: criterion, relative to the stretch's energy (120 dB of prediction gain; below, rounding).
PREDICTION_FLOOR = 1e-12
#: The free ringing of the first bounce is taken from this long after the first onset (past
#: the contact), s.
CLEAN_GUARD = 0.002
#: Default floor of the detection, dB under the strongest frame of the whitened signal, in
#: steps 1-6 (a guard against what the 20 ms predictor leaves of the earlier ticks, which
#: those steps do not model over their whole response) and for the test that calls step 7.
DYNAMIC_RANGE_DB = 60.0
#: Frame length of the noise-floor estimate, s, and the spread of its quiet frames, dB.
NOISE_FRAME = 0.01
NOISE_SPREAD_DB = 3.0


class AnalysisError(SynthError, ValueError):
    """The recording cannot be analysed: unreadable, silent, clipped, or without ticks."""


@dataclass(frozen=True)
class Tick:
    """One detected tick (SI units).

    Attributes
    ----------
    index : int
        1 for the first tick.
    time : float
        Onset, s from the start of the recording.
    bounce_time : float or None
        Time since the previous tick's onset ``t_n``, s (the flight plus the
        previous contact); ``None`` for the first tick.
    restitution : float or None
        ``e_n = t_n / t_(n-1)``, dimensionless: the restitution of the previous
        tick's impact as the thesis defines it from bounce times (section 3.1).
        Bounce times hold the contact times, so it exceeds the impact's physical
        restitution (rebound over impact speed) by ``(tau_n / e_n - tau_(n-1)) /
        t_(n-1)`` (module docstring): of the order of contact time over bounce time.
        ``None`` for the first two ticks.
    speed : float or None
        Impact speed ``v_n = g t_n / 2``, m/s (the flight alone gives ``g (t_n -
        tau) / 2``: this exceeds it by ``g tau / 2``); ``None`` for the first tick.
    energy : float
        Sum of squares of the tick's own signal (without the other ticks) over its
        window divided by the sample rate, signal units^2 s.
    peak : float
        Largest magnitude of the tick's own signal, signal units.
    centroid : float
        Spectral centroid (power-weighted mean frequency), Hz.
    spread : float
        Spectral spread (power-weighted standard deviation of frequency), Hz.
    decay_time : float or None
        Time for the amplitude envelope to fall to 1/e of its peak, s; ``None``
        when the window is too short to fit it.
    window : float
        Length of the measurement window, s: ``window`` of :func:`analyze` for every
        tick, shorter only where the recording ends.
    strength : float
        How far the tick's whitened energy stands above the threshold it had to
        clear, dB; for a tick that step 7 found by description length (no threshold
        cleared), how far that fell with it, in dB of residual energy per sample.
    """

    index: int
    time: float
    bounce_time: float | None
    restitution: float | None
    speed: float | None
    energy: float
    peak: float
    centroid: float
    spread: float
    decay_time: float | None
    window: float
    strength: float


@dataclass(frozen=True)
class Analysis:
    """The ticks found in one recording.

    Attributes
    ----------
    ticks : list of Tick
        In time order.
    samplerate : float
        Sample rate, Hz.
    duration : float
        Length of the recording, s.
    noise_floor : float
        RMS of the noise estimate, signal units.
    gravity : float
        Gravity used for the speeds, m/s^2.
    channel : int or None
        The channel analysed; ``None`` when the channels were mixed (mean).
    clipped : bool
        True when the recording looks clipped.
    warnings : tuple of str
        What the measurements should be read with (clipping).
    """

    ticks: list[Tick]
    samplerate: float
    duration: float
    noise_floor: float
    gravity: float
    channel: int | None
    clipped: bool
    warnings: tuple[str, ...]

    @property
    def mean_restitution(self) -> float | None:
        """Mean of the defined ``e_n``, dimensionless; ``None`` when there is none."""
        e = [t.restitution for t in self.ticks if t.restitution is not None]
        return float(np.mean(e)) if e else None


# ---------------------------------------------------------------------------
# validation


def _audio_array(audio) -> np.ndarray:
    a = audio if isinstance(audio, np.ndarray) else np.asarray(audio)
    if a.dtype == bool or not (np.issubdtype(a.dtype, np.floating)
                               or np.issubdtype(a.dtype, np.integer)):
        raise ParameterError(f"audio must hold real samples (floats), not dtype {a.dtype}")
    if a.ndim not in (1, 2):
        raise ParameterError(f"audio must be (frames,) or (frames, channels), got shape {a.shape}")
    if a.size == 0:
        raise ParameterError(f"audio is empty (shape {a.shape})")
    a = a.astype(np.float64, copy=False)
    finite = np.isfinite(a)
    if not finite.all():
        raise ParameterError(
            f"audio holds {a.size - int(np.count_nonzero(finite))} NaN or infinite samples; "
            f"all must be finite")
    return a if a.ndim == 2 else a[:, None]


def _channel(channel, n: int) -> int | None:
    if channel is None:
        return None
    if isinstance(channel, (bool, np.bool_)) or not isinstance(channel, (int, np.integer)):
        raise ParameterError(f"channel={channel!r} must be None (mix) or a channel index")
    if not 0 <= channel < n:
        raise ParameterError(
            f"channel={channel!r} is out of range: the audio has {n} channel(s), "
            f"allowed 0..{n - 1} or None (mix)")
    return int(channel)


def _integer(name: str, value, lo: int) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ParameterError(f"{name}={value!r} must be an integer >= {lo}")
    if value < lo:
        raise ParameterError(f"{name}={value!r} must be >= {lo}")
    return int(value)


def _samples(name: str, value, fs: float, lo: int = 1) -> int:
    """A duration in s, as a whole number of samples (at least ``lo``)."""
    t = checks.positive(name, value, "s")
    n = int(round(t * fs))
    if n < lo:
        raise ParameterError(
            f"{name}={value!r} is shorter than {lo} sample(s) at {fs:g} Hz (s)")
    return n


def _analysis(name: str, value) -> Analysis:
    if not isinstance(value, Analysis):
        raise ParameterError(
            f"{name} must be an Analysis (from analyze or analyze_file), "
            f"not {type(value).__name__}")
    return value


# ---------------------------------------------------------------------------
# numerics


def _lpc(x: np.ndarray, order: int) -> np.ndarray:
    """Prediction-error filter ``[1, a1, ..., ap]`` of ``x`` (autocorrelation method).

    The autocorrelation up to lag ``order`` is summed over blocks by FFT (exact:
    each block is correlated with itself extended by ``order`` samples); the zero
    lag is raised by 1e-9 (a -90 dB white-noise correction) so that a noiseless
    sum of a few sinusoids stays solvable.
    """
    from scipy.fft import irfft, next_fast_len, rfft
    from scipy.linalg import solve_toeplitz

    block = max(4 * order, 1 << 16)
    nfft = next_fast_len(block + order, real=True)
    r = np.zeros(order + 1)
    for s in range(0, x.size, block):
        a = rfft(x[s: s + block], nfft)
        b = rfft(x[s: s + block + order], nfft)
        r += irfft(np.conj(a) * b, nfft)[: order + 1]
    r[0] *= 1.0 + 1e-9
    return np.concatenate(([1.0], solve_toeplitz(r[:order], -r[1:])))


def _covariance(x: np.ndarray, p: int) -> np.ndarray:
    """``C[i, j] = sum_{t=p}^{N-1} x[t-i] x[t-j]`` for ``i, j = 0..p`` (the normal equations
    of the covariance method of linear prediction, Makhoul 1975 section 3.1.2).

    Row 0 from the full autocorrelation by FFT less the first ``p`` products; then
    ``C[i+1, j+1] = C[i, j] + x[p-1-i] x[p-1-j] - x[N-1-i] x[N-1-j]``, row by row:
    O(N log N + p^2).
    """
    from scipy.fft import irfft, next_fast_len, rfft

    n = x.size
    nfft = next_fast_len(n + p + 1, real=True)
    X = rfft(x, nfft)
    full = irfft(X * np.conj(X), nfft)[: p + 1]       # sum_t x[t] x[t+d]
    head = np.array([np.dot(x[d:p], x[: p - d]) for d in range(p + 1)])
    C = np.empty((p + 1, p + 1))
    C[0] = full - head
    u = x[p - 1:: -1][:p]               # x[p-1-i], i = 0..p-1
    v = x[n - 1:: -1][:p]               # x[n-1-i]
    for i in range(p):
        C[i + 1, i + 1:] = C[i, i:p] + u[i] * u[i:p] - v[i] * v[i:p]
    iu = np.triu_indices(p + 1, 1)
    C[(iu[1], iu[0])] = C[iu]
    return C


def _stable(a: np.ndarray) -> bool:
    """Whether the prediction-error filter ``a`` (``a[0] = 1``) is minimum phase, its all-pole
    model ``1/A`` stable: every reflection coefficient of the step-down (backward Levinson)
    recursion below 1 in magnitude (the Schur-Cohn test)."""
    a = np.asarray(a, dtype=float)
    for m in range(a.size - 1, 0, -1):
        k = a[m]
        if not abs(k) < 1.0:
            return False
        a = (a[:m] - k * a[m:0:-1]) / (1.0 - k * k)
    return True


def _resonator_predictor(seg: np.ndarray, fs: float, start: int):
    """The prediction-error filter of the free ringing ``seg`` (the covariance method: least
    squares over the stretch, no window), of an order chosen by the data; None when the
    stretch is too short or no order gives a stable all-pole model. Module docstring,
    step 7.

    The order minimises the description length ``N ln(E_m / N) + m ln N`` (Rissanen 1983,
    Ann. Stat. 11, 416) of the prediction error energy ``E_m`` over the ``N`` predicted
    samples (never below :data:`PREDICTION_FLOOR` of the stretch's energy), over a grid of
    96 orders; every predictor comes from one Cholesky factorisation at the largest order
    (its leading blocks factor the smaller systems). The orders tried start at ``start`` and
    double while the best lies in the top quarter, up to a third of the stretch (two
    equations per unknown, at least) and :data:`MAX_ORDER`. Then the normal equations are
    solved again with the least prediction error energy added to their diagonal: the
    noise, which no order predicts, as white noise (a ridge), so that no predictor lifts a
    band that the ringing leaves empty (above its modes, under an anti-aliasing filter) far
    over the noise there; without noise it changes nothing. Of the orders tried, the one
    of least description length whose all-pole model is stable is taken (a resonator's
    modes all decay; the measurements go through ``1/A``).
    """
    from scipy.linalg import LinAlgError, cholesky, solve_triangular
    from scipy.signal import oaconvolve

    cap = min(MAX_ORDER, (seg.size - 1) // 3)
    if cap < 2 or not np.any(seg):
        return None

    def factor(G, load):
        for _ in range(4):
            try:
                return cholesky(G + load * np.eye(G.shape[0]), lower=True, check_finite=False)
            except LinAlgError:
                load *= 100.0
        return None

    def description(Lc, C):
        # the prediction error energy of each order's predictor over the same samples, on a
        # grid of orders (never below PREDICTION_FLOOR of the stretch's energy: rounding),
        # and the description length
        p = Lc.shape[0]
        y = solve_triangular(Lc, C[1:, 0], lower=True, check_finite=False)
        n = seg.size - p
        grid = np.unique(np.round(np.geomspace(1, p, 96)).astype(int))
        energy = np.empty(grid.size)
        for i, order in enumerate(grid):
            a = np.concatenate(([1.0], -solve_triangular(
                Lc[:order, :order].T, y[:order], lower=False, check_finite=False)))
            err = oaconvolve(seg, a)[p: seg.size]
            energy[i] = max(float(np.dot(err, err)), PREDICTION_FLOOR * C[0, 0])
        return grid, energy, n * np.log(energy / n) + grid * math.log(n), y

    p_max = min(cap, max(start, 2))
    while True:
        C = _covariance(seg, p_max)
        G = C[1:, 1:]
        Lc = factor(G, 1e-12 * np.trace(G) / p_max)
        if Lc is None:
            return None
        grid, energy, mdl, y = description(Lc, C)
        best = int(grid[int(np.argmin(mdl))])
        if best <= 0.75 * p_max or p_max >= cap:
            break
        p_max = min(cap, 2 * p_max)
    # what no order predicts is the noise: as much white noise is added to the normal
    # equations (a ridge: the least error energy on the diagonal), so that no predictor
    # lifts a band the ringing leaves empty (above the modes, under an anti-aliasing
    # filter) far over the noise there, where a tick's onset would drown
    Lc = factor(G, max(float(energy.min()), 1e-12 * np.trace(G) / p_max))
    if Lc is None:
        return None
    grid, energy, mdl, y = description(Lc, C)
    # the stable predictor of least description length
    for i in np.argsort(mdl, kind="stable"):
        order = int(grid[i])
        a = np.concatenate(([1.0], -solve_triangular(
            Lc[:order, :order].T, y[:order], lower=False, check_finite=False)))
        if _stable(a):
            return a
    return None


def _noise_floor(x: np.ndarray, fs: float) -> float:
    """RMS of the 10 ms frames within 3 dB of the quietest one, signal units."""
    n = max(1, int(round(NOISE_FRAME * fs)))
    frames = x.size // n
    if frames == 0:
        return float(np.sqrt(np.mean(x * x)))
    ms = np.mean(x[: frames * n].reshape(frames, n) ** 2, axis=1)
    quiet = ms[ms <= ms.min() * 10.0 ** (NOISE_SPREAD_DB / 10.0)]
    return float(np.sqrt(quiet.mean()))


def _clipping(chans: np.ndarray, min_count: int):
    """The clipped samples of each channel and a warning, or ``(None, None)``.

    A channel is clipped at its positive (negative) extreme when ``min_count`` or more of
    its samples sit at exactly its largest (smallest) value.
    """
    mask = np.zeros(chans.shape, dtype=bool)
    worst = None
    for c in range(chans.shape[1]):
        col = chans[:, c]
        for level in (col.max(), col.min()):
            if level == 0.0:
                continue
            at = col == level
            count = int(np.count_nonzero(at))
            if count >= min_count:
                mask[:, c] |= at
        count = int(np.count_nonzero(mask[:, c]))
        if count and (worst is None or count > worst[1]):
            worst = (c, count, float(np.abs(col).max()))
    if worst is None:
        return None, None
    c, count, peak = worst
    total = int(np.count_nonzero(mask))
    return mask, (
        f"clipping: {total} samples sit at a channel's extreme ({count} in channel {c}, "
        f"magnitude {peak:.6g}); they were interpolated from the signal's linear predictor "
        f"before the ticks were sought, but the loudest ticks' peaks, energies and spectra "
        f"are unreliable, and their onsets and bounce times may be off too")


def _ar_interpolate(x: np.ndarray, missing: np.ndarray, a: np.ndarray) -> np.ndarray:
    """``x`` with the samples at ``missing`` replaced by their least-squares estimate under
    the prediction-error filter ``a`` (Janssen, Veldhuis and Vries 1986, IEEE Trans. ASSP
    34, 317): minimise ``sum (a * x)^2`` over the missing samples. Each clipped sample
    keeps at least its clipped magnitude (its sign and level are known): a sample whose
    estimate falls short is fixed there and the rest are solved again.
    """
    from scipy.linalg import solveh_banded
    from scipy.signal import correlate, oaconvolve

    p = a.size - 1
    ra = correlate(a, a, mode="full")[p:]           # autocorrelation of a, lags 0..p
    y = x.copy()
    level = x[missing]
    free = np.nonzero(missing)[0]
    for _ in range(4):
        if free.size == 0:
            break
        y[free] = 0.0
        e0 = oaconvolve(y, a)[: y.size + p]         # prediction error with the gaps at 0
        # b_i = -sum_k a_k e0[i + k]
        b = -correlate(e0, a, mode="valid")[free]
        # G_ij = ra(|pos_i - pos_j|), zero beyond lag p: banded in index order
        bw = int(np.max(np.searchsorted(free, free + p, side="right") - np.arange(free.size))) - 1
        bw = max(bw, 0)
        ab = np.zeros((bw + 1, free.size))
        for k in range(bw + 1):
            lag = free[k:] - free[: free.size - k]
            ab[bw - k, k:] = np.where(lag <= p, ra[np.minimum(lag, p)], 0.0)
        ab[bw] *= 1.0 + 1e-9
        v = solveh_banded(ab, b)
        short = np.abs(v) < np.abs(x[free])
        short |= np.sign(v) != np.sign(x[free])
        y[free] = v
        if not short.any():
            break
        fixed = free[short]
        y[fixed] = x[fixed]
        free = free[~short]
    y[missing] = np.where(np.abs(y[missing]) < np.abs(level), level, y[missing])
    return y


def _declip(chans: np.ndarray, mask: np.ndarray, order: int):
    """The mix of ``chans`` with each channel's clipped samples interpolated, and the
    whitening predictor of the repaired mix.

    The interpolating predictor is fitted to the channel after its last clipped sample when
    that holds at least ``4 order`` samples (the unclipped ringing of the same resonator),
    else to the whole channel; its order is 3 times the longest clipped run (Janssen et
    al. recommend at least that), at least 1 ms, at most the whitening order.
    """
    out = np.empty_like(chans)
    for c in range(chans.shape[1]):
        col, m = chans[:, c], mask[:, c]
        if not m.any():
            out[:, c] = col
            continue
        idx = np.nonzero(m)[0]
        breaks = np.nonzero(np.diff(idx) > 1)[0]
        runs = np.diff(np.r_[-1, breaks, idx.size - 1])
        p = int(min(order, max(3 * int(runs.max()), order // 20, 8)))
        tail = col[idx[-1] + 1:]
        a = _lpc(tail if tail.size >= 4 * order else col, p)
        out[:, c] = _ar_interpolate(col, m, a)
    x = out[:, 0] if out.shape[1] == 1 else out.mean(axis=1)
    return x, _lpc(x, order)


def _detect(r: np.ndarray, fs: float, hop: int, min_sep: int, background: float,
            threshold_db: float, rise_db: float, release: float, dynamic_range_db: float,
            max_drop_db: float):
    """Ticks in the whitened signal ``r`` (module docstring, steps 2 and 3).

    Returns the tick frames, the detection function ``d`` (energy of ``r`` per
    frame), each frame's threshold and the local background (energy per frame).
    """
    from scipy.ndimage import median_filter
    from scipy.signal import find_peaks

    # frame k: the energy of r over [k hop, k hop + w), w at least MIN_FRAME samples
    # (frames overlap at low rates, so that a frame of noise is never a sum of
    # only a few squares, whose large scatter would pass for a tick)
    w = max(hop, MIN_FRAME)
    d = np.lib.stride_tricks.sliding_window_view(r * r, w)[::hop].sum(axis=1)
    frames = d.size
    size = max(3, int(round(background * fs / hop)) | 1)
    med = median_filter(d, size=size, mode="nearest")
    # memory of frames j <= k - 2 (frame k - 1 may hold the start of the same
    # burst), fading by `release` dB per ms; in log10 units
    # max_j (log d_j - a (k - j)) = max_j (log d_j + a j) - a k
    a = release * 1000.0 * hop / fs / 10.0
    aj = np.arange(frames) * a
    with np.errstate(divide="ignore"):
        memory = np.maximum.accumulate(np.log10(d) + aj)
    past = np.zeros_like(d)
    past[2:] = 10.0 ** (memory[:-2] - aj[2:])
    threshold = np.maximum.reduce([
        med * 10.0 ** (threshold_db / 10.0),
        past * 10.0 ** (rise_db / 10.0),
        np.full_like(d, d.max() * 10.0 ** (-dynamic_range_db / 10.0)),
    ])
    q = np.where(d >= threshold, d, 0.0)
    candidates = find_peaks(np.concatenate(([0.0], q, [0.0])))[0] - 1
    keep, energies = [], []
    drop = 10.0 ** (-max_drop_db / 10.0)
    for k in candidates:
        if keep and (k - keep[-1]) * hop < min_sep:
            continue                # the first candidate of a cluster is the tick
        energy = d[k: k + 2].max()  # its burst may straddle two frames
        if keep and energy < energies[-1] * drop:
            continue
        keep.append(k)
        energies.append(energy)
    return np.array(keep, dtype=int), d, threshold, med


def _refine(r: np.ndarray, lo: int, hi: int, fraction: float, gap: int,
            noise: float, strict: bool = False) -> float:
    """Sub-sample onset (samples) of the burst of the whitened signal ``r`` peaking in
    ``[lo, hi)`` (module docstring, step 4)."""
    mag = np.abs(r)
    k = lo + int(np.argmax(mag[lo:hi]))
    level = max(fraction * mag[k], min(noise, mag[k]))
    i = k
    while True:
        j0 = max(0, i - gap)
        above = np.nonzero(mag[j0:i] >= level)[0]
        if above.size == 0:
            break
        i = j0 + int(above[0])
    # a run of samples alternating in sign and growing towards the burst is the
    # pre-ringing of a linear-phase anti-aliasing filter (acausal, at the Nyquist rate),
    # not the contact: the burst is a sampled sinc, and the contact its centre. With
    # r[m] = A sinc(f) and r[m+1] = A sinc(1 - f), the two samples either side of the
    # centre m + f (same sign), r[m+1] / r[m] = f / (1 - f)
    m = i
    while m < k and r[m] * r[m + 1] < 0.0 and mag[m] < mag[m + 1]:
        m += 1
    # (with ``strict``, the run's samples stand above the noise: a few alternating samples
    # of the earlier ticks' remainders are not a filter's pre-ringing)
    floor = min(noise, mag[k]) if strict else 0.0
    j = m
    while j > 0 and r[j - 1] * r[j] < 0.0 and floor <= mag[j - 1] < mag[j]:
        j -= 1
    if m - j >= PRE_RINGING_RUN and mag[m] >= 0.25 * mag[k]:
        rho = mag[m + 1] / mag[m] if m + 1 < r.size and r[m] * r[m + 1] > 0.0 else 0.0
        return m + rho / (1.0 + rho)
    if i == 0:
        return 0.0
    return (i - 1) + (level - mag[i - 1]) / (mag[i] - mag[i - 1])


def _delay(y: np.ndarray, template: np.ndarray, lo: float, hi: float) -> float:
    """Sub-sample delay (samples, within ``[lo, hi]``) of ``y`` behind ``template``: the
    peak of their cross-correlation with the phase transform (each frequency's cross
    spectrum ``Y T*`` taken at unit magnitude; Knapp and Carter 1976, IEEE Trans. ASSP
    24, 320), interpolated band-limited (module docstring, step 7).

    For ``y = h * template`` it is the delay ``d`` whose linear phase best fits the phase of
    the filter ``h`` over the band, ``max sum_f cos(arg H(f) - 2 pi f d)``: every frequency
    counts once, so the band where the whitened responses carry most of their energy (near
    the Nyquist frequency) sets no lobes two samples apart, and a ratio of pulse shapes of
    zero phase that keeps its sign over the band (a longer symmetric contact, shorter than
    3 sample periods for a half-sine) moves the delay by its centre alone.
    """
    n = 1 << int(math.ceil(math.log2(y.size + template.size)))
    C = np.fft.rfft(y, n) * np.conj(np.fft.rfft(template, n))
    mag = np.abs(C)
    # unit magnitude, but for bins 240 dB under the strongest (rounding: they have no phase)
    C = np.where(mag > 1e-12 * mag.max(), C / np.maximum(mag, 1e-300), 0.0)
    # band-limited interpolation of the (circular) correlation: its spectrum zero-padded
    # DELAY_UPSAMPLING times (the Nyquist bin split between the two halves), then a
    # parabola through the finest grid's peak
    up = DELAY_UPSAMPLING
    if n % 2 == 0:
        C[-1] *= 0.5
    c = np.fft.irfft(C, n * up)
    i0 = int(math.ceil(lo * up))
    i1 = int(math.floor(hi * up))
    lags = np.arange(i0, i1 + 1)
    k = int(lags[np.argmax(c[lags % c.size])])
    a, b, d = c[(k - 1) % c.size], c[k % c.size], c[(k + 1) % c.size]
    den = a - 2.0 * b + d
    frac = 0.5 * (a - d) / den if den < 0.0 else 0.0
    return (k + min(0.5, max(-0.5, frac))) / up


def _frame_energies(z: np.ndarray, hop: int, w: int) -> np.ndarray:
    """Energy of ``z`` over frames ``[k hop, k hop + w)`` (the detection function)."""
    if z.size < w:
        return np.zeros(0)
    return np.lib.stride_tricks.sliding_window_view(z * z, w)[::hop].sum(axis=1)


class _Deflation:
    """Tick-by-tick detection on the whitened signal with the earlier ticks taken out
    (module docstring, step 5; with ``exact``, step 7).

    ``q`` is the whitened signal ``r`` minus the whitened responses of the ticks found so
    far, each modelled as the first tick's response ``T`` through a short FIR filter
    fitted by least squares; ``r - q`` is what was taken out. With ``exact`` (the
    resonator's search), ``T`` is a list of templates (the first tick's whitened response
    and those of the next ticks taken whole), each tick is modelled through a filter on
    each, and ``expect`` holds what each model is expected to leave (per sample), against
    which a candidate's energy is weighed instead of all that was taken out.
    """

    def __init__(self, r, template, start, fs, hop, w, background, threshold_db, rise_db,
                 release, floor, subtracted_db, noise, exact=False):
        self.exact = exact
        self.r = r
        self.q = r.copy()
        self.T = [template]
        # energy per sample that each model is expected to leave (its fit's relative
        # error, raised by REMAINDER_MARGIN_DB, times its energy there)
        self.expect = np.zeros_like(r)
        self.hop = hop
        self.w = w
        self.bg = max(3, int(round(background * fs / hop)))
        self.thr = 10.0 ** (threshold_db / 10.0)
        self.rise = rise_db / 10.0
        self.fade = release * 1000.0 * hop / fs / 10.0     # log10 units per frame
        self.floor = floor
        self.kappa = 10.0 ** (subtracted_db / 10.0)
        self.noise = noise * noise * w      # energy per frame of the whitened noise floor
        self.span = max(2, int(round(REMAINDER_SPAN * fs / hop)))
        # lags of the FIR filter, samples: a little before (onset error) and after (a
        # longer pulse than the first tick's)
        self.pre = max(1, int(round(DEFLATION_PRE * fs)))
        self.post = max(1, int(round(DEFLATION_POST * fs)))
        self.post_long = max(self.post, int(round(RESONATOR_POST * fs)))
        self.q[start: start + template.size] -= template

    def candidate(self, after: int):
        """The first tick in ``q`` starting at or after sample ``after``: ``(frame start,
        frame energy, threshold, local background, first frame above the threshold)``
        (energies per frame), or None."""
        from scipy.ndimage import median_filter

        hop, w, bg = self.hop, self.w, self.bg
        q = self.q
        lo = max(0, after - (4 * bg + 2) * hop)
        chunk = max(8 * bg * hop, 4096)
        while True:
            hi = min(q.size, after + chunk)
            seg = q[lo:hi]
            d = _frame_energies(seg, hop, w)
            if d.size == 0:
                return None
            if self.exact:
                sub = _frame_energies(np.sqrt(self.expect[lo:hi]), hop, w)
            else:
                sub = _frame_energies(self.r[lo:hi] - seg, hop, w)
            first = -(-(after - lo) // hop)
            k = np.arange(d.size)
            # local background: median of the frames k-2-bg .. k-3 (the past, with the
            # earlier ticks taken out; frame k-1 may hold the start of this burst)
            med = median_filter(d, size=bg, mode="nearest")
            past_med = np.full_like(d, np.inf)
            j = k - 2 - bg // 2 - 1
            ok = j >= bg // 2
            # never below the noise floor (the first tick's stretch of q is exactly 0)
            past_med[ok] = np.maximum(med[j[ok]], self.noise)
            # memory of frames j <= k - 2, fading by `release` dB/ms (as in _detect)
            with np.errstate(divide="ignore"):
                memory = np.maximum.accumulate(np.log10(d) + k * self.fade)
            past = np.zeros_like(d)
            past[2:] = 10.0 ** (memory[:-2] - k[2:] * self.fade + self.rise)
            threshold = np.maximum.reduce([
                np.where(np.isfinite(past_med), past_med * self.thr, 0.0), past,
                np.full_like(d, self.floor), sub * self.kappa])
            # and over the frames from k-1 on spanning REMAINDER_SPAN, more energy than was
            # taken out there: a model a fraction of a sample off leaves its remainder
            # spread over the frames around a burst
            span = np.ones(self.span)
            d_near = np.convolve(d, span)[self.span - 2: self.span - 2 + d.size]
            sub_near = np.convolve(sub, span)[self.span - 2: self.span - 2 + d.size]
            hit = np.nonzero((d >= threshold) & (d_near >= sub_near * self.kappa)
                             & (k >= first))[0]
            if hit.size:
                first_hit = m = int(hit[0])
                while m + 1 < d.size and d[m + 1] > d[m]:
                    m += 1                      # on to the frame's local maximum
                noise = past_med[m] if np.isfinite(past_med[m]) else threshold[m] / self.thr
                # the threshold the burst cleared: its first frame's
                return (lo + m * hop, float(d[m]), float(max(threshold[first_hit], 1e-300)),
                        float(noise), lo + first_hit * hop)
            if hi >= q.size:
                return None
            chunk *= 2

    def remove(self, s: int, end: int, joint=(), alone=None) -> np.ndarray:
        """Fit ``q[s:end] ~ sum_j (h_j * T_j)`` over the templates ``T_j``, take the fit out
        of ``q`` from ``s`` on and return it (from ``s`` on).

        Without ``exact``: one template, lags ``-pre .. post``. With it, the lags span
        ``-pre .. post_long`` (a contact up to :data:`RESONATOR_POST` longer than the
        first tick's), ``-pre .. post`` or ``-1 .. 2`` samples, over all templates or the
        first few: of the choices with at least :data:`FIT_SAMPLES_PER_TAP` samples per
        unknown, the one of least description length ``W ln(RSS) + P ln W`` (``W``
        samples, ``P`` unknowns); the model is expected to leave, outside the window, its
        relative error in the window raised by :data:`REMAINDER_MARGIN_DB`, counted up to
        ``alone`` (sample; the soonest next bounce the series allows: beyond, the window may
        hold a later tick that no model there explains, whose energy is no error of this
        one). ``joint`` (with ``exact``): the starts of later ticks in the window, modelled
        alike (``P`` counts their unknowns) and fitted with this one, whose models are not
        taken out.
        """
        q = self.q
        W = min(end, q.size) - s
        if W <= 0:
            return np.zeros(0)
        if not self.exact:
            # one template, lags -pre .. post
            T = self.T[0]
            pre, post = self.pre, self.post
            if W < 2 * (pre + post + 1):
                pre = post = 0                      # too short a window for a filter
            ntap = pre + post + 1
            # M[i, j] = T[i - l_j] with lags l_j = post - j
            Tp = np.concatenate((np.zeros(post), T[: W + pre],
                                 np.zeros(pre + max(0, W - T.size))))
            M = np.lib.stride_tricks.sliding_window_view(Tp, ntap)[:W]
            G = M.T @ M
            G[np.diag_indices(ntap)] += 1e-9 * np.trace(G) / ntap + 1e-300
            h = np.linalg.solve(G, M.T @ q[s: s + W])
            # contribution at s + t: sum_j h_j T[t - l_j]
            contrib = np.convolve(T, h[::-1])[pre:]
            n = min(contrib.size, q.size - s)
            q[s: s + n] -= contrib[:n]
            return contrib
        y = q[s: s + W].copy()
        offsets = [0] + [int(o) - s for o in joint]
        _, Ts, pre, post, h, res = self.choose(y, offsets)
        ntap = pre + post + 1
        # contribution at s + t: sum_j h_j T[t - l_j] (this tick's taps come first)
        n_c = max(T.size for T in Ts) + post
        contrib = np.zeros(n_c)
        for i, T in enumerate(Ts):
            c = np.convolve(T, h[i * ntap: (i + 1) * ntap][::-1])[pre:]
            contrib[: c.size] += c
        n = min(contrib.size, q.size - s)
        q[s: s + n] -= contrib[:n]
        # the relative error of the fit (of all the ticks fitted together) up to ``alone``:
        # beyond, the window may hold later ticks that no model explains yet
        model = y - res
        m = W if alone is None else max(1, min(W, int(alone) - s))
        rss = float(np.dot(res[:m], res[:m]))
        fitted = float(np.dot(model[:m], model[:m]))
        eps = min(1.0, 10.0 ** (REMAINDER_MARGIN_DB / 10.0) * rss / max(fitted, 1e-300))
        self.expect[s: s + n] += eps * contrib[:n] ** 2
        return contrib

    def choose(self, y, offsets=(0,)):
        """The models of ticks started at ``offsets`` (samples into ``y``) fitted to ``y``
        (with ``exact``): of the choices of templates and lags with at least
        :data:`FIT_SAMPLES_PER_TAP` samples per unknown, the one of least description length
        ``W ln(RSS) + P ln W``: ``(description length, templates, pre, post, taps,
        residual)`` (one tap per template, on as many as the window allows, when no filter
        fits it)."""
        W = y.size
        K = len(offsets)
        best = None
        for n_t in range(len(self.T), 0, -1):
            for pre, post in ((self.pre, self.post_long), (self.pre, self.post), (1, 2)):
                P = K * n_t * (pre + post + 1)
                if W < FIT_SAMPLES_PER_TAP * P:
                    continue
                fit = self._fit(self.T[:n_t], y, pre, post, offsets)
                rss = max(float(np.dot(fit[1], fit[1])), 1e-300 * float(np.dot(y, y)) + 1e-300)
                crit = W * math.log(rss) + P * math.log(W)
                if best is None or crit < best[0]:
                    best = (crit, self.T[:n_t], pre, post, fit[0], fit[1])
        if best is None:
            # too short a window for filters: one tap on as many templates as it allows
            n_t = max(1, min(len(self.T), W // (FIT_SAMPLES_PER_TAP * K)))
            h, res = self._fit(self.T[:n_t], y, 0, 0, offsets)
            rss = max(float(np.dot(res, res)), 1e-300 * float(np.dot(y, y)) + 1e-300)
            best = (W * math.log(rss) + K * n_t * math.log(W), self.T[:n_t], 0, 0, h, res)
        return best

    @staticmethod
    def _fit(Ts, y, pre, post, offsets=(0,)):
        """Least-squares filters (lags ``-pre .. post``) of the templates ``Ts``, started at
        each of ``offsets`` (samples into ``y``), fitting ``y``: the taps (offset by offset,
        template by template) and the residual."""
        W = y.size
        ntap = pre + post + 1
        cols = []
        for o in offsets:
            for T in Ts:
                # M[i, j] = T[i - o - l_j] with lags l_j = post - j
                Tp = np.concatenate((np.zeros(post + o), T[: max(0, W - o + pre)],
                                     np.zeros(pre + max(0, W - o - T.size))))
                cols.append(np.lib.stride_tricks.sliding_window_view(Tp, ntap)[:W])
        M = np.concatenate(cols, axis=1)
        G = M.T @ M
        P = G.shape[0]
        G[np.diag_indices(P)] += 1e-12 * np.trace(G) / P + 1e-300
        h = np.linalg.solve(G, M.T @ y)
        return h, y - M @ h

    def take(self, s: int, n: int) -> np.ndarray:
        """Take ``q[s:s+n]`` as a new template (a tick alone over its whole whitened
        response): out of ``q``, and returned."""
        T = self.q[s: s + n].copy()
        self.q[s: s + n] = 0.0
        self.T.append(T)
        return T


def _decay_time(y: np.ndarray, fs: float, n: int, floor: float) -> float | None:
    """1/e time of the envelope of ``y`` (smoothed over ``n`` samples), s, or None."""
    if y.size < 2 * n:
        return None
    w = np.hanning(n + 2)[1:-1]
    env = np.sqrt(np.convolve(y * y, w / w.sum(), mode="same"))
    env = env[: env.size - n // 2]          # the last half-window feels the window's end
    k = int(np.argmax(env))
    seg = env[k:]
    low = np.nonzero(seg <= floor * 10.0 ** (DECAY_NOISE_MARGIN_DB / 20.0))[0]
    if low.size:
        seg = seg[: low[0]]
    if seg.size < max(3, n):
        return None
    slope = np.polyfit(np.arange(seg.size) / fs, np.log(seg), 1)[0]
    if not -slope * seg.size / fs >= DECAY_MIN_FALL:
        return None
    return float(-1.0 / slope)


def _spectral_moments(y: np.ndarray, fs: float) -> tuple[float, float]:
    """Power-weighted mean and standard deviation of frequency, Hz."""
    n = y.size
    taper = np.cos(0.5 * np.pi * np.arange(n) / n) ** 2      # falling half of a Hann window
    nfft = 1 << max(12, int(math.ceil(math.log2(2 * n))))
    p = np.abs(np.fft.rfft(y * taper, nfft)) ** 2
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    total = p.sum()
    if not total > 0.0:
        return 0.0, 0.0
    c = float(np.dot(f, p) / total)
    return c, float(np.sqrt(np.dot((f - c) ** 2, p) / total))


def _separation(onsets, strengths, min_sep: int, e_min: float) -> int:
    """Shortest plausible bounce after the last of ``onsets`` (samples): ``min_separation``,
    and ``e_min`` times the last bounce time unless the last tick is doubtful (module
    docstring, step 5)."""
    if len(onsets) < 2 or strengths[-1] < DOUBTFUL_DB:
        return min_sep
    return max(min_sep, int(math.ceil(e_min * (onsets[-1] - onsets[-2]))))


def _soonest(onsets, strengths, min_sep: int) -> int:
    """Shortest plausible bounce after the last of ``onsets`` in the resonator's search
    (samples): ``(1 - RESTITUTION_STEP)`` times the last restitution times the last bounce
    (a restitution changes slowly along a series), after a tick that is not doubtful;
    else ``min_separation``."""
    if len(onsets) < 3 or strengths[-1] < DOUBTFUL_DB:
        return min_sep
    t = onsets[-1] - onsets[-2]
    return max(1, int(math.ceil((1.0 - RESTITUTION_STEP) * t * t / (onsets[-2] - onsets[-3]))))


def _bounce_series(onsets: np.ndarray, e_min: float, growth: float = BOUNCE_GROWTH,
                   horizon: int = SERIES_HORIZON) -> list[int]:
    """Indices in ``onsets`` of the longest bounce series that starts at the first tick
    (module docstring, step 3).

    A series is a subsequence of the candidates whose every bounce time lies between
    ``e_min`` and ``growth`` times the one before; the longest is found by dynamic
    programming over the first ``horizon`` candidates (of equally long ones, the one whose
    second tick comes first).
    """
    t = np.asarray(onsets[:horizon], dtype=float)
    n = t.size
    if n < 3:
        return list(range(n))
    # best[i, j]: most ticks in a series from tick 0 ending ..., t_i, t_j; second[i, j]:
    # its second tick; back[i, j]: the tick before t_i
    best = np.zeros((n, n), dtype=int)
    second = np.zeros((n, n), dtype=int)
    back = np.full((n, n), -1, dtype=int)
    best[0, 1:] = 2
    second[0, 1:] = np.arange(1, n)
    for i in range(1, n - 1):
        col, sec = best[:i, i], second[:i, i]
        for j in range(i + 1, n):
            bounce = t[j] - t[i]
            # the bounce before, t_i - t_k, must lie in [bounce / growth, bounce / e_min]
            lo = np.searchsorted(t[:i], t[i] - bounce / e_min, side="left")
            hi = np.searchsorted(t[:i], t[i] - bounce / growth, side="right")
            if hi <= lo:
                continue
            c = col[lo:hi]
            m = int(c.max())
            if m == 0:
                continue
            pick = np.nonzero(c == m)[0]
            k = lo + int(pick[np.argmin(sec[lo:hi][pick])])
            best[i, j] = m + 1
            second[i, j] = second[k, i]
            back[i, j] = k
    top = best.max()
    ends = np.argwhere(best == top)
    i, j = min(ends, key=lambda ij: (second[ij[0], ij[1]], ij[1]))
    chain = [int(j), int(i)]
    while back[i, j] >= 0:
        i, j = back[i, j], i
        chain.append(int(i))
    if chain[-1] != 0:
        chain.append(0)
    return chain[::-1]


def _too_strong(onsets, strengths, energies, on: float, energy: float) -> bool:
    """Whether a candidate at ``on`` (samples) with whitened frame energy ``energy`` is
    stronger than its bounce time allows (module docstring, step 5): more than
    :data:`MAX_EXCESS_DB` above ``(t_n / t_(n-1))^2`` times the last tick's energy, that
    tick being trusted (not doubtful)."""
    if len(onsets) < 2 or strengths[-1] < DOUBTFUL_DB:
        return False
    ratio = (on - onsets[-1]) / (onsets[-1] - onsets[-2])
    return energy > energies[-1] * ratio * ratio * 10.0 ** (MAX_EXCESS_DB / 10.0)


def _deflated_onsets(r, fs, onset1, strength1, energy1, end1, anchors, hop, min_sep, e_min,
                     background, threshold_db, rise_db, release, floor, fraction, gap, keep,
                     exact=False, known=(), strongest=None):
    """Ticks after the first, found one by one with the earlier ticks taken out (module
    docstring, step 5; with ``exact``, the resonator's search of step 7, whose rules it
    applies: templates, the fit windows' search, the shortest bounce the series allows,
    the onset walk, each tick's model fitted again jointly with the next tick's).
    ``anchors`` (onsets, samples, and their strengths, dB) are the ticks of step 3's
    bounce series: none is passed over. ``known`` (onsets, samples) are the ticks of the
    first search, which decide whether the second tick is a template. ``floor`` (energy
    per frame) is the floor of the dynamic range, or None for step 7's own (the whitened
    noise and the last tick), never under :data:`PREDICTION_FLOOR` of ``strongest``, the
    strongest frame of ``r`` (step 3's detection function).

    Returns the onsets (samples), strengths (dB), the residual ``q`` (``r`` with every
    tick's model taken out), each tick's model (its whitened response from its window's
    start, at most ``keep`` samples), and what the whitening leaves of the first tick's
    ringing in the second half of the first bounce, relative to its strongest frame (its
    median frame energy over its largest, a power ratio), and with ``exact`` the onsets
    timed against the first tick's template (samples; else None).
    """
    w = max(hop, MIN_FRAME)
    s1 = max(int(math.floor(onset1)) - WINDOW_GUARD, 0)
    template = r[s1: max(end1, s1 + 1)].copy()
    noise = _noise_floor(r, fs)
    e_t = _frame_energies(template, hop, w)
    left = (float(np.median(e_t[e_t.size // 2:]) / e_t.max())
            if e_t.size > 1 and e_t.max() > 0.0 else 0.0)
    cut = 10.0 ** (TEMPLATE_NOISE_DB / 10.0) * noise * noise * w
    # step 7 with the default dynamic range: no fixed floor under the strongest frame but
    # the whitened noise floor raised by the threshold (never under PREDICTION_FLOOR of the
    # strongest frame: rounding), and max_drop_db under the last tick (``e_min^2`` times its
    # energy: a bounce's tick goes as its impact speed squared); the earlier ticks'
    # remainders are weighed by their models
    relative = floor is None
    if relative:
        floor = max(10.0 ** (threshold_db / 10.0) * noise * noise * w,
                    PREDICTION_FLOOR * strongest)
    if exact:
        cut = max(cut, floor * 10.0 ** (-TEMPLATE_FLOOR_DB / 10.0))
    # the template ends where it sinks into the noise (or under the floor): beyond, taking
    # it out of a later tick would only add its noise
    loud = np.nonzero(e_t > cut)[0]
    if loud.size:
        template = template[: min(template.size, int(loud[-1]) * hop + w)]
    dfl = _Deflation(r, template, s1, fs, hop, w, background, threshold_db, rise_db, release,
                     floor, DEFLATION_KAPPA_DB, noise, exact)
    L = template.size
    onsets, strengths, energies = [float(onset1)], [float(strength1)], [float(energy1)]
    models = [template[:keep].copy()]
    # with ``exact``, the onsets timed by cross-correlation against the first tick's template
    timed = [float(onset1)]
    anchor_on, anchor_strength = anchors
    known = np.asarray(known, dtype=float)
    after = int(math.floor(onset1)) + min_sep
    # with ``exact``: the last tick's window start, and ``q`` and ``expect`` from there as
    # they were before its model was taken out (None after the first tick and a template)
    prev = None

    def separation(ons, strs):
        if exact:
            return _soonest(ons, strs, min_sep)
        return _separation(ons, strs, min_sep, e_min)

    def timing(start, model, level_crossing):
        # the onset of a tick whose window starts at ``start``, timed against the first
        # tick's whitened response: the delay of its model behind that template (within the
        # lags of its filters), from the template's own onset; a model of nothing keeps the
        # level crossing
        if not np.any(model):
            return level_crossing
        return onset1 + (start - s1) + _delay(model, dfl.T[0], -dfl.pre, dfl.post_long)

    def drop_floor(energy):
        if relative:
            dfl.floor = max(floor, e_min * e_min * energy)

    def further():
        # no candidate clears the rules: one more tick of the series, where the series allows
        # the next bounce, against none, by description length (``W ln(E) + P ln W``, as the
        # filters' choice) over a window holding the last tick's response, its model not
        # taken out, and the new tick's: the last tick's model alone, or jointly with the new
        # one's (module docstring, step 7). Returns (onset, strength, energy) or None.
        ps, psaved, _ = prev
        t_last = onsets[-1] - onsets[-2]
        ratio = t_last / (onsets[-2] - onsets[-3])
        if ratio >= 1.0:
            # a bounce longer than the one before: a tick was missed in between (a ball's
            # flights only shorten), whose response no model holds
            return None
        # from the soonest next bounce the series allows to the latest, as window starts
        lo = int(math.ceil(onsets[-1])) + separation(onsets, strengths) - WINDOW_GUARD
        hi = int(math.floor(onsets[-1] + BOUNCE_GROWTH * ratio * t_last)) - WINDOW_GUARD
        # the window: from the last tick's start to a last bounce past the latest place
        end = min(r.size, hi + WINDOW_GUARD + int(t_last))
        if end - hi < 2 or lo > hi:
            return None
        y = np.concatenate((psaved, dfl.q[ps + psaved.size: end]))[: end - ps]
        W = y.size
        null = dfl.choose(y)[0]
        places = range(lo, hi + 1, HYPOTHESIS_STEP)
        # only where the residual clears the floor (the dynamic range asked for, the
        # whitened noise, max_drop_db under the last tick), as any candidate must: a tick
        # elsewhere would be refused whatever its description length, and each place tried
        # costs a fit of every choice of templates and lags
        # (the energies of the frames starting at every sample: a place's burst is its
        # frames at 0, hop and 2 hop, as a candidate's)
        e_s = _frame_energies(dfl.q[lo: hi + w + 2 * hop], 1, w)
        best = None
        for p in places:
            k = p - lo
            burst = e_s[k: k + 2 * hop + 1: hop]
            energy = float(burst.max()) if burst.size else 0.0
            if energy < dfl.floor:
                continue
            # the place is one of len(places) (all of the range, tried or not): ln(len(places))
            # nats more to describe, twice that in the criterion (twice a code length in nats,
            # as W ln E + P ln W)
            crit = dfl.choose(y, (0, p - ps))[0] + 2.0 * math.log(len(places))
            if best is None or crit < best[0]:
                best = (crit, p, energy)
        if best is None or best[0] >= null:
            return None
        p, energy = best[1], best[2]
        # its strength: the fall of the description length per sample, in dB of residual
        return float(p + WINDOW_GUARD), 10.0 / math.log(10.0) * (null - best[0]) / W, energy

    drop_floor(energies[-1])
    while True:
        c = dfl.candidate(after)
        # the next tick of step 3's series, when this search would pass over it
        nxt = np.nonzero(anchor_on > onsets[-1] + min_sep)[0]
        a = int(nxt[0]) if nxt.size else None
        if a is not None and (c is None or anchor_on[a] < c[0] - min_sep):
            on, strength = float(anchor_on[a]), float(anchor_strength[a])
            i0 = int(math.floor(on))
            burst = _frame_energies(dfl.q[max(0, i0 - w + 1): i0 + w + 2 * hop], hop, w)
            energy = float(burst.max()) if burst.size else 0.0
        elif c is None:
            hyp = further() if exact and prev is not None and len(onsets) >= 3 else None
            if hyp is None:
                break
            on, strength, energy = hyp
        else:
            pos, energy, thr_k, bg, first = c
            # onset: the walk of step 4 on q, not back past the previous tick (with
            # ``exact``, nor more than a frame before the first frame that cleared the
            # threshold: further back lie the earlier ticks' remainders, not this burst)
            lo = int(math.floor(onsets[-1])) + 1
            if exact:
                lo = max(lo, first - w)
            hi = min(r.size, pos + w + 2 * hop)
            sigma = ONSET_NOISE_SIGMAS * math.sqrt(bg / w)
            on = lo + _refine(dfl.q[lo:hi], max(0, pos - hop - lo), hi - lo, fraction, gap,
                              sigma, strict=exact)
            # the burst's energy: the largest frame holding its first samples (the
            # candidate frame may be an earlier one on its rising edge)
            i0 = int(math.floor(on))
            burst = _frame_energies(dfl.q[max(0, i0 - w + 1): i0 + w + 2 * hop], hop, w)
            energy = max(energy, float(burst.max())) if burst.size else energy
            near = np.abs(anchor_on - on) < min_sep
            if not near.any() and (
                    on - onsets[-1] < separation(onsets, strengths)
                    or _too_strong(onsets, strengths, energies, on, energy)):
                after = pos + hop           # part of the previous tick's response
                continue
            strength = 10.0 * math.log10(energy / thr_k)
            if near.any():
                strength = max(strength, float(anchor_strength[near].max()))
        drop_floor(energy)
        s = max(int(math.floor(on)) - WINDOW_GUARD, 0)
        after = int(math.floor(on)) + separation(onsets + [on], strengths + [strength])

        def fit_end():
            nxt = dfl.candidate(after)
            if nxt is None:
                return s + L
            return min(s + L, (nxt[4] if exact else nxt[0]) - hop)

        # fit over the tick's own stretch, up to the next tick; if taking this one out
        # removes what looked like the next tick (its own remainder), fit again longer
        # (with ``exact``, and shorter if it uncovers an earlier one)
        e = fit_end()
        saved = dfl.q[s: s + L + dfl.post_long + 1].copy()
        saved_expect = dfl.expect[s: s + saved.size].copy()

        def restore():
            dfl.q[s: s + saved.size] = saved
            dfl.expect[s: s + saved.size] = saved_expect

        uncovered = False
        if exact and len(onsets) >= 2 and strength >= DOUBTFUL_DB:
            # while this tick is in q it may hide the next one, which the series puts
            # between (1 - RESTITUTION_STEP) and BOUNCE_GROWTH times the last restitution
            # times this bounce after it: windows ending from the soonest on, each 10 %
            # longer, until one uncovers a tick at its end
            t_last = on - onsets[-1]
            ratio = t_last / (onsets[-1] - onsets[-2])
            end = s + int((1.0 - RESTITUTION_STEP) * ratio * t_last)
            latest = min(e, s + int(BOUNCE_GROWTH * ratio * t_last) + hop)
            while end < latest:
                dfl.remove(s, end, alone=after)
                c = dfl.candidate(after)
                restore()
                if c is not None and c[4] <= end + 2 * hop:
                    e = max(c[4] - hop, int(math.floor(on)) + 1)
                    uncovered = True
                    break
                end = max(end + hop, s + int(1.1 * (end - s)))
        model = dfl.remove(s, e, alone=after)
        for _ in range(0 if uncovered else DEFLATION_REFITS - 1):
            e2 = fit_end()
            if e2 <= e and not (exact and e2 < e):
                break
            restore()
            e = e2
            model = dfl.remove(s, e, alone=after)
        if len(onsets) >= 2:
            # the soonest next bounce the series allows (its restitution changes slowly)
            t_last = on - onsets[-1]
            clear = (1.0 - RESTITUTION_STEP) * t_last * t_last / (onsets[-1] - onsets[-2])
        else:
            # the second tick: up to the next tick the first search found (a tick it missed
            # between would be stronger than that one: the ticks of a series only weaken)
            later = known[known > on + min_sep]
            clear = later[0] - s if later.size else 0.0
        template_taken = False
        if (exact and len(dfl.T) < MAX_TEMPLATES and strength >= ANCHOR_DB
                and L < end1 - s1 and clear >= L + w):
            # a sure tick alone over its whole whitened response: a template itself
            restore()
            model = dfl.take(s, L)
            e = s + L
            template_taken = True
        if exact and prev is not None and not template_taken:
            # the previous tick's model was fitted up to where this tick shows (a bounce: 1.1
            # ms for the board's last ones, too short a window for the filters of a long
            # contact), while its response goes on under this tick: fitted again, jointly
            # with this tick's over this tick's window, both ticks' filters over the whole
            # span; then this tick's alone again, with the previous one's new model out
            ps, psaved, psaved_expect = prev
            restore()
            dfl.q[ps: ps + psaved.size] = psaved
            dfl.expect[ps: ps + psaved.size] = psaved_expect
            pmodel = dfl.remove(ps, e, joint=(s,), alone=after)
            models[-1] = pmodel[:keep].copy()
            timed[-1] = timing(ps, pmodel, timed[-1])
            saved = dfl.q[s: s + L + dfl.post_long + 1].copy()
            saved_expect = dfl.expect[s: s + saved.size].copy()
            model = dfl.remove(s, e, alone=after)
        prev = None if template_taken or not exact else (s, saved, saved_expect)
        onsets.append(float(on))
        strengths.append(strength)
        energies.append(float(energy))
        models.append(model[:keep].copy())
        if exact:
            timed.append(timing(s, model, float(on)))

    return (np.array(onsets), np.array(strengths), dfl.q, models, left,
            np.array(timed) if exact else None)


def _in_order(on, kept, e_min, growth) -> bool:
    """Whether the last bounce of the ticks ``kept`` lies within ``e_min`` and ``growth``
    times the one before (true when there is no bounce before)."""
    if len(kept) < 3:
        return True
    before = on[kept[-2]] - on[kept[-3]]
    return e_min * before <= on[kept[-1]] - on[kept[-2]] <= growth * before


def _bounce_order(onsets: np.ndarray, strengths: np.ndarray, e_min: float,
                  growth: float = BOUNCE_GROWTH) -> np.ndarray:
    """Indices of the ticks that keep the order of a bounce series (module docstring,
    step 6).

    Taken in time order after the first two: a tick sooner than ``e_min`` times the last
    bounce time after the last tick is dropped (part of that tick's response). Where a
    bounce time is over ``growth`` times the one before, the tick that ends the shorter
    bounce, or the one that starts it, is dropped when it is weaker than the new tick and
    its removal restores the order (it split a bounce in two; the weaker of the two if
    both do), or else the last few ticks, when all are weaker than the new tick and not
    sure and their removal restores the order; else the new tick is dropped if doubtful (a late remainder) and kept if
    not (a missed tick, or a second drop). Last, a
    tick that is not sure is dropped when the bounce across it continues the series'
    restitution (within ``RESTITUTION_STEP``) and the two bounces it makes do not.
    """
    on = onsets
    kept = list(range(min(2, on.size)))
    for i in range(2, on.size):
        t_last = on[kept[-1]] - on[kept[-2]]
        t = on[i] - on[kept[-1]]
        if t < e_min * t_last:
            # too soon for a bounce: part of the last tick's response, unless the last
            # tick is a doubtful remainder just before this stronger one
            if (strengths[kept[-1]] < DOUBTFUL_DB and strengths[i] > strengths[kept[-1]]
                    and _in_order(on, kept[:-1] + [i], e_min, growth)):
                kept[-1] = i
            continue
        if t > growth * t_last:
            # one of the two ticks of the short bounce, weaker than this one, split a
            # bounce in two: drop the weaker of those whose removal restores the order
            options = [j for j in (len(kept) - 1, len(kept) - 2)
                       if j >= 2 and strengths[kept[j]] < strengths[i]
                       and _in_order(on, kept[:j] + kept[j + 1:] + [i], e_min, growth)
                       and _in_order(on, kept[:j] + kept[j + 1:], e_min, growth)]
            # or the last few ticks, all weaker than this one and not sure, split it
            run = None
            for m in range(2, len(kept) - 1):
                if max(strengths[j] for j in kept[-m:]) >= min(strengths[i], ANCHOR_DB):
                    break
                if _in_order(on, kept[:-m] + [i], e_min, growth):
                    run = m
                    break
            if options:
                del kept[min(options, key=lambda j: strengths[kept[j]])]
            elif run is not None:
                del kept[-run:]
            elif strengths[i] < DOUBTFUL_DB:
                continue                    # a late remainder
        kept.append(i)
    # a tick that is not sure, between two others, is dropped when the bounce across it
    # continues the series' restitution and the two bounces it makes do not (a
    # restitution changes slowly along a series, with the impact speed: PHYSICS.md
    # section 5)
    k = 3
    while k + 1 < len(kept):
        t = on[kept[k - 3: k + 2]]
        if strengths[kept[k]] < ANCHOR_DB:
            e_before = (t[2] - t[1]) / (t[1] - t[0])
            split = max(abs((t[3] - t[2]) / (t[2] - t[1]) / e_before - 1.0),
                        abs((t[4] - t[3]) / (t[3] - t[2]) / e_before - 1.0))
            merged = abs((t[4] - t[2]) / (t[2] - t[1]) / e_before - 1.0)
            if merged < RESTITUTION_STEP < split:
                del kept[k]
                continue
        k += 1
    return np.array(kept, dtype=int)


def _first_ticks(r, fs, hop_n, min_sep, bg, thr, rise, rel, dyn, drop, frac, gap, e_min):
    """Steps 2-4 on the whitened signal ``r``: the candidate frames from the first tick on
    (the first tick's own response, before the second tick, left out), their onsets
    (samples) and strengths (dB), the detection function, and the sure ticks of the bounce
    series (onsets and strengths)."""
    peaks, d, threshold, med = _detect(r, fs, hop_n, min_sep, bg, thr, rise, rel, dyn, drop)
    if peaks.size == 0:
        raise AnalysisError("no tick detected: nothing rises above the background "
                            "(is this a recording of impacts?)")
    w = max(hop_n, MIN_FRAME)
    # the background is an energy per frame of w samples
    sigma = ONSET_NOISE_SIGMAS * np.sqrt(med[peaks] / w)
    # frame k spans [k hop, k hop + w): search it and a hop either side
    onsets = np.array([
        _refine(r, max(0, (k - 1) * hop_n), min(r.size, k * hop_n + w + hop_n), frac, gap, s)
        for k, s in zip(peaks, sigma)])
    # a candidate whose refined onset walks back to within min_separation of the
    # previous tick's is part of that tick's burst
    kept = []
    for i in range(onsets.size):
        if onsets[i] == 0.0:
            continue        # a burst from the first sample on: the recording's cut
        if not kept or onsets[i] - onsets[kept[-1]] >= min_sep:
            kept.append(i)
    if not kept:
        raise AnalysisError("no tick detected: nothing rises above the background "
                            "(is this a recording of impacts?)")
    peaks, onsets = peaks[kept], onsets[kept]
    strength = 10.0 * np.log10(d[peaks] / threshold[peaks])
    anchors, anchor_strength = onsets[:1], strength[:1]
    if peaks.size > 1:
        # the candidates before the second tick are the first tick's own response
        series = _bounce_series(onsets, e_min)
        anchors, anchor_strength = onsets[series], strength[series]
        sure = np.r_[True, anchor_strength[1:] >= ANCHOR_DB]
        anchors, anchor_strength = anchors[sure], anchor_strength[sure]
        keep = np.r_[0, series[1]:peaks.size]
        peaks, onsets, strength = peaks[keep], onsets[keep], strength[keep]
    return peaks, onsets, strength, d, anchors, anchor_strength


# ---------------------------------------------------------------------------
# public API


def analyze(audio, samplerate, *, gravity=9.81, channel=None, min_separation=0.001,
            hop=0.00025, threshold_db=10.0, rise_db=6.0, release=5.0,
            dynamic_range_db=None, max_drop_db=20.0, background=0.02, onset_fraction=0.1,
            lpc_order=None, window=0.02, subtract_tails=True, deflate=True,
            decay_smoothing=0.002, clip_samples=4, on_clipping="warn") -> Analysis:
    """Detect the ticks of a bouncing sound and measure them (module docstring).

    Parameters
    ----------
    audio : array of float, (frames,) or (frames, channels)
        The recording, in any signal units (energies and peaks are in them).
    samplerate : float > 0
        Sample rate, Hz.
    gravity : float > 0
        Gravity for the impact speeds ``v_n = g t_n / 2``, m/s^2.
    channel : int or None
        The channel to analyse (0-based); ``None`` mixes them (mean).
    min_separation : float > 0
        Shortest time between two ticks, s: a burst closer than this to a tick is part
        of it (default 1 ms). Longer contacts are told apart by the bounce-series rules
        (steps 3, 5 and 6); lower it (0.2 ms) for hard balls whose last bounces are
        shorter than 1 ms.
    hop : float > 0
        Spacing of the detection function's frames, s (at least one sample; each
        frame spans at least 12 samples).
    threshold_db : float > 0
        Margin above the local background, dB.
    rise_db : float > 0
        Margin above the fading memory of the earlier frames, dB.
    release : float > 0
        How fast that memory fades, dB per ms.
    dynamic_range_db : float > 0, optional
        Ticks more than this below the strongest frame of the whitened signal are ignored,
        dB, in every step. Default: :data:`DYNAMIC_RANGE_DB` (60 dB) in steps 1-6; in the
        resonator's search (step 7), which models every earlier tick and weighs a candidate
        against what those models are expected to leave, no fixed range: the floor there is
        the whitened noise floor raised by ``threshold_db`` and ``max_drop_db`` under the
        last tick (module docstring, step 7).
    max_drop_db : float > 0
        A tick more than this below the previous tick is ignored, dB (20 dB: a
        restitution below 0.1); it also sets the shortest plausible bounce,
        ``10^(-max_drop_db / 20)`` times the previous one.
    background : float > 0
        Length of the running median giving the local background, s.
    onset_fraction : float in (0, 1)
        Level of the onset crossing, as a fraction of the burst's peak.
    lpc_order : int >= 2, optional
        Order of the whitening predictor. Default: 20 ms of samples, at least 8, and where
        the first tick rings on under it, the resonator's own predictor (step 7). Given,
        that order alone (no step 7).
    window : float > 0
        Length of every tick's measurement window, s (shorter only where the recording
        ends).
    subtract_tails : bool
        Measure each tick's own sound (its excitation through the resonator's all-pole
        model, without the other ticks); False measures the recording over the window.
    deflate : bool
        Find the ticks after the first one by one, each with the earlier ticks' whitened
        responses taken out (steps 5 and 7); False keeps the ticks of step 3.
    decay_smoothing : float > 0
        Length of the Hann window smoothing the envelope for the decay fit, s
        (at least 3 samples).
    clip_samples : int >= 2
        Samples at exactly a channel's largest (or smallest) value that mean clipping.
    on_clipping : {"warn", "raise"}
        Report clipping in :attr:`Analysis.warnings`, or raise ``AnalysisError``.

    Returns
    -------
    Analysis

    Raises
    ------
    ParameterError
        Bad input; the message names the field and its value.
    AnalysisError
        A silent recording, one without a detectable tick, or a clipped one with
        ``on_clipping="raise"``.
    """
    chans = _audio_array(audio)
    fs = checks.positive("samplerate", samplerate, "Hz")
    g = checks.positive("gravity", gravity, "m/s^2")
    ch = _channel(channel, chans.shape[1])
    min_sep = _samples("min_separation", min_separation, fs)
    hop_n = _samples("hop", hop, fs)
    thr = checks.positive("threshold_db", threshold_db, "dB")
    rise = checks.positive("rise_db", rise_db, "dB")
    rel = checks.positive("release", release, "dB/ms")
    dyn = (DYNAMIC_RANGE_DB if dynamic_range_db is None
           else checks.positive("dynamic_range_db", dynamic_range_db, "dB"))
    drop = checks.positive("max_drop_db", max_drop_db, "dB")
    bg = checks.positive("background", background, "s")
    frac = checks.in_range("onset_fraction", onset_fraction, 0.0, 1.0)
    win_n = _samples("window", window, fs)
    dec_n = _samples("decay_smoothing", decay_smoothing, fs, lo=3)
    clip_n = _integer("clip_samples", clip_samples, 2)
    checks.choice("on_clipping", on_clipping, ("warn", "raise"))
    for name, flag in (("subtract_tails", subtract_tails), ("deflate", deflate)):
        if not isinstance(flag, (bool, np.bool_)):
            raise ParameterError(f"{name}={flag!r} must be True or False")
    order = (max(8, int(round(0.02 * fs))) if lpc_order is None
             else _integer("lpc_order", lpc_order, 2))

    used = chans if ch is None else chans[:, [ch]]
    n_frames = used.shape[0]
    if n_frames <= 2 * order:
        raise ParameterError(
            f"audio has {n_frames} frames: too short for a whitening predictor of order {order} "
            f"(needs more than {2 * order})")
    if not np.any(used):
        raise AnalysisError("the audio is silent: every sample of the analysed signal is 0")
    warnings = []
    clip_mask, clip = _clipping(used, clip_n)
    if clip is not None:
        if on_clipping == "raise":
            raise AnalysisError(clip)
        warnings.append(clip)
    x = used[:, 0] if used.shape[1] == 1 else used.mean(axis=1)
    if not np.any(x):
        raise AnalysisError("the audio is silent: the mean of the channels is 0 everywhere")

    from scipy.signal import lfilter, oaconvolve

    if clip is not None:
        x, A = _declip(used, clip_mask, order)
    else:
        A = _lpc(x, order)
    # the prediction error, the recording taken as silent before its first sample
    r = oaconvolve(x, A)[: x.size]
    e_min = 10.0 ** (-drop / 20.0)
    gap = max(2, int(round(ONSET_GAP * fs)))
    detect = (fs, hop_n, min_sep, bg, thr, rise, rel, dyn, drop, frac, gap, e_min)

    def search(r, exact=0, known=()):
        # steps 2-5 (with exact, the order of the resonator's predictor: step 7) on the
        # whitened signal r: onsets, strengths, residual, models, and what is left of the
        # first tick's ringing in the second half of the first bounce (None without a
        # second tick)
        args = detect
        if exact:
            # each tick's whitened response lasts about the predictor's order: the local
            # background is the median over BACKGROUND_SPAN of them
            args = detect[:3] + (max(bg, BACKGROUND_SPAN * exact / fs),) + detect[4:]
        peaks, onsets, strength, d, anchors, anchor_strength = _first_ticks(r, *args)
        if not deflate:
            return onsets, strength, None, None, None, peaks, None
        end1 = (peaks[1] - 1) * hop_n if peaks.size > 1 else r.size
        if exact and peaks.size > 1:
            # the first bounce ends where the second tick's burst begins
            end1 = min(end1, max(int(math.floor(onsets[1])) - WINDOW_GUARD, 1))
        onsets, strength, q, models, left, timed = _deflated_onsets(
            r, fs, onsets[0], strength[0], d[peaks[0]: peaks[0] + 2].max(), end1,
            (anchors[1:], anchor_strength[1:]), hop_n, min_sep, e_min, bg, thr, rise, rel,
            None if exact and dynamic_range_db is None else d.max() * 10.0 ** (-dyn / 10.0),
            frac, gap, win_n, bool(exact), known, float(d.max()))
        return onsets, strength, q, models, left if peaks.size > 1 else None, peaks, timed

    onsets, strength, q, models, left, peaks, _ = search(r)
    kept = _bounce_order(onsets, strength, e_min)
    # per tick: its onset, strength, model, which search found it (0: steps 2-6, 1: 7) and
    # the onset its search detected it at (where its model and its window start)
    found = [(onsets[i], strength[i], None if models is None else models[i], 0, onsets[i])
             for i in kept]
    sources = [(A, r, q)]
    if (left is not None and left > 10.0 ** (-dyn / 10.0) and lpc_order is None
            and clip is None):
        # step 7: the first tick rings on above the floor up to the second under the
        # whitening; the resonator's own predictor, from the free ringing of the first
        # bounce, and the search again
        lo = int(math.floor(onsets[0])) + int(round(CLEAN_GUARD * fs))
        hi = (peaks[1] - 1) * hop_n
        a_res = _resonator_predictor(x[lo:hi], fs, order) if hi > lo else None
        res = None
        if a_res is not None:
            r_res = oaconvolve(x, a_res)[: x.size]
            try:
                res = search(r_res, a_res.size - 1, onsets[kept])
            except AnalysisError:
                res = None
        # kept when it leaves RESONATOR_GAIN_DB less of the first tick's ringing and agrees
        # with the first search on the ticks that one found, which it continues
        if res is not None and res[4] is not None and (
                res[4] < left * 10.0 ** (-RESONATOR_GAIN_DB / 10.0)):
            on2, st2, q2, models2 = res[:4]
            timed2 = res[6]
            kept2 = _bounce_order(on2, st2, e_min)
            on2 = on2[kept2]
            tol = AGREEMENT * fs
            n = 0
            while (n < min(len(found), on2.size)
                   and abs(on2[n] - found[n][0]) <= tol):
                n += 1
            if n >= 2 and (n == len(found) or on2.size > n and on2[n] < found[n][0] - tol):
                sources.append((a_res, r_res, q2))
                # its ticks, those it shares with the first search too, timed against the
                # first tick's template: one estimator for every bounce time
                found = ([(timed2[kept2[j]],) + found[j][1:] for j in range(n)]
                         + [(timed2[kept2[j]], st2[kept2[j]], models2[kept2[j]], 1, on2[j])
                            for j in range(n, on2.size)])
    onsets = np.array([f[0] for f in found])
    strength = np.array([f[1] for f in found])

    noise = _noise_floor(x, fs)
    starts = np.maximum(np.floor([f[4] for f in found]).astype(int) - WINDOW_GUARD, 0)
    ticks = []
    for i, (on, s) in enumerate(zip(onsets, starts)):
        e = min(x.size, s + win_n)
        if not subtract_tails:
            y = x[s:e].copy()
        else:
            # the tick's own excitation, through the resonator's all-pole model 1/A (of the
            # search that found it)
            A_i, r_i, q_i = sources[found[i][3]]
            exc = np.zeros(e - s)
            stop = min(e, starts[i + 1]) if i + 1 < starts.size else e
            if found[i][2] is not None:
                # the tick's model, and what no tick explains up to the next tick (beyond,
                # that is the later ticks' remainders)
                m = found[i][2][: e - s]
                exc[: m.size] += m
                exc[: stop - s] += q_i[s:stop]
            else:
                exc[: stop - s] = r_i[s:stop]
            y = lfilter([1.0], A_i, exc)
        bt = None if i == 0 else float((on - onsets[i - 1]) / fs)
        prev = None if i < 2 else (onsets[i - 1] - onsets[i - 2]) / fs
        c, sp = _spectral_moments(y, fs)
        ticks.append(Tick(
            index=i + 1, time=float(on / fs), bounce_time=bt,
            restitution=None if prev is None else float(bt / prev),
            speed=None if bt is None else float(g * bt / 2.0),
            energy=float(np.dot(y, y) / fs), peak=float(np.abs(y).max()),
            centroid=c, spread=sp, decay_time=_decay_time(y, fs, dec_n, noise),
            window=float(y.size / fs), strength=float(strength[i])))
    return Analysis(ticks=ticks, samplerate=fs, duration=x.size / fs,
                    noise_floor=noise, gravity=g, channel=ch, clipped=clip is not None,
                    warnings=tuple(warnings))


def read_recording(path) -> tuple[np.ndarray, float]:
    """Read a sound file for :func:`analyze`: every channel, as it is stored.

    Parameters
    ----------
    path : str or path-like
        The file (WAV, FLAC, OGG, AIFF, ... at any sample rate, any number of channels).

    Returns
    -------
    audio : ndarray of float64, (frames, channels)
        The samples, in units of full scale.
    samplerate : float
        Sample rate, Hz.

    Raises
    ------
    ParameterError
        ``path`` is not a file name, or no such file.
    AnalysisError
        An unreadable file (corrupt header, unknown format) or one without samples.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise ParameterError(f"path={path!r} must be a file name, not {type(path).__name__}")
    if not os.path.isfile(path):
        raise ParameterError(f"path={os.fspath(path)!r}: no such file")
    import soundfile

    try:
        audio, samplerate = soundfile.read(path, dtype="float64", always_2d=True)
    except (soundfile.SoundFileError, RuntimeError, TypeError, ValueError) as exc:
        raise AnalysisError(f"cannot read {os.fspath(path)!r} as sound: {exc}") from None
    if audio.shape[0] == 0:
        raise AnalysisError(f"{os.fspath(path)!r} holds no samples")
    return audio, float(samplerate)


def analyze_file(path, *, gravity=9.81, channel=None, **options) -> Analysis:
    """Read a sound file (any format and rate soundfile reads) and :func:`analyze` it.

    Parameters
    ----------
    path : str or path-like
        The file (WAV, FLAC, OGG, AIFF, ...).
    gravity : float > 0
        Gravity for the impact speeds, m/s^2.
    channel : int or None
        The channel to analyse (0-based); ``None`` mixes them (mean).
    **options
        The other keyword arguments of :func:`analyze`.

    Raises
    ------
    ParameterError
        A missing file or bad options.
    AnalysisError
        An unreadable file (corrupt header, unknown format) and the cases of
        :func:`analyze`.
    """
    audio, samplerate = read_recording(path)
    return analyze(audio, samplerate, gravity=gravity, channel=channel, **options)


# ---------------------------------------------------------------------------
# presentation

#: Columns of :func:`format_table` and :func:`to_csv`: (field, heading, unit, scale, format).
_COLUMNS = (
    ("index", "n", "", 1.0, "d"),
    ("time", "time", "s", 1.0, ".5f"),
    ("bounce_time", "bounce", "ms", 1e3, ".3f"),
    ("restitution", "e", "", 1.0, ".4f"),
    ("speed", "speed", "m/s", 1.0, ".4f"),
    ("energy", "energy", "u^2 s", 1.0, ".4g"),
    ("peak", "peak", "u", 1.0, ".4g"),
    ("centroid", "centroid", "Hz", 1.0, ".0f"),
    ("spread", "spread", "Hz", 1.0, ".0f"),
    ("decay_time", "decay", "ms", 1e3, ".2f"),
    ("strength", "strength", "dB", 1.0, ".1f"),
)


def format_table(analysis, *, warnings=True) -> str:
    """A terminal table of the ticks, one line each, with a summary header.

    Columns: n, time (s), bounce time (ms), e, speed (m/s), energy (signal
    units^2 s), peak (signal units), centroid (Hz), spread (Hz), decay (ms),
    strength (dB). Undefined values print as ``-``. With ``warnings`` (default) the
    analysis' warnings follow the header, one line each (the command line prints
    them to stderr instead).
    """
    an = _analysis("analysis", analysis)
    if not isinstance(warnings, (bool, np.bool_)):
        raise ParameterError(f"warnings={warnings!r} must be True or False")
    e = an.mean_restitution
    lines = [
        f"{len(an.ticks)} ticks in {an.duration:.3f} s at {an.samplerate:g} Hz, "
        f"channel {'mix' if an.channel is None else an.channel}, "
        f"noise floor {an.noise_floor:.3g}, mean e "
        f"{'-' if e is None else format(e, '.4f')}, g {an.gravity:g} m/s^2"]
    if warnings:
        lines += [f"warning: {w}" for w in an.warnings]
    head = [h + (f" ({u})" if u else "") for _, h, u, _, _ in _COLUMNS]
    rows = []
    for t in an.ticks:
        row = []
        for name, _, _, scale, fmt in _COLUMNS:
            v = getattr(t, name)
            row.append("-" if v is None else format(v * scale if scale != 1.0 else v, fmt))
        rows.append(row)
    widths = [max(len(h), *(len(r[j]) for r in rows)) if rows else len(h)
              for j, h in enumerate(head)]
    lines.append("  ".join(h.rjust(w) for h, w in zip(head, widths)))
    lines += ["  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in rows]
    return "\n".join(lines)


def to_dict(analysis) -> dict:
    """The analysis as plain JSON-ready data (SI units; ``None`` where undefined)."""
    an = _analysis("analysis", analysis)
    out = {f.name: getattr(an, f.name) for f in fields(an) if f.name != "ticks"}
    out["warnings"] = list(an.warnings)
    out["mean_restitution"] = an.mean_restitution
    out["units"] = {"time": "s", "bounce_time": "s", "speed": "m/s",
                    "energy": "signal units^2 s", "peak": "signal units", "centroid": "Hz",
                    "spread": "Hz", "decay_time": "s", "window": "s", "strength": "dB",
                    "samplerate": "Hz", "duration": "s", "noise_floor": "signal units",
                    "gravity": "m/s^2"}
    out["ticks"] = [asdict(t) for t in an.ticks]
    return out


def to_csv(analysis) -> str:
    """The ticks as CSV: a header of the :class:`Tick` field names, SI units, one row each.

    Undefined values are empty cells.
    """
    an = _analysis("analysis", analysis)
    names = [f.name for f in fields(Tick)]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(names)
    for t in an.ticks:
        w.writerow(["" if getattr(t, n) is None else repr(getattr(t, n)) for n in names])
    return buf.getvalue()


def check_plot_path(path) -> str:
    """Check that an image can be written to ``path`` before any work is done.

    The directory must exist and be writable, and the suffix must name an image format
    matplotlib writes (.png, .pdf, .svg, ...). Returns the format (the suffix, lower
    case).

    Raises
    ------
    ParameterError
        A bad path or format; the message names ``path``.
    SynthError
        matplotlib is not installed (``pip install matplotlib``).
    """
    if not isinstance(path, (str, os.PathLike)):
        raise ParameterError(f"path={path!r} must be a file name, not {type(path).__name__}")
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise ParameterError(f"path={path!r}: directory {folder!r} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ParameterError(f"path={path!r}: directory {folder!r} is not writable")
    if os.path.isdir(path):
        raise ParameterError(f"path={path!r} is a directory, not an image file name")
    fmt = os.path.splitext(path)[1].lstrip(".").lower()
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
    except ImportError:
        raise SynthError("plotting needs matplotlib: pip install matplotlib") from None
    formats = FigureCanvasAgg.get_supported_filetypes()
    if fmt not in formats:
        raise ParameterError(
            f"path={path!r}: image format {fmt!r} is not one of {', '.join(sorted(formats))}")
    return fmt


def plot_analysis(analysis, audio, samplerate, path):
    """Draw the analysis to an image file (format from the suffix: .png, .pdf, .svg ...).

    Four panels: the analysed signal with the detected onsets; bounce time (ms)
    and restitution per bounce; tick energy on a log scale against bounce
    number, with the line ``E_1 ebar^(2 (n - 1))`` through the first tick
    (``ebar`` the mean restitution); centroid (Hz) and decay time (ms) per
    bounce. Written to a temporary file beside ``path`` and renamed onto it.

    Parameters
    ----------
    analysis : Analysis
        From :func:`analyze` of the same audio.
    audio : array of float, (frames,) or (frames, channels)
        The recording that was analysed, with all its channels (the analysis says
        which channel, or the mix, it used).
    samplerate : float > 0
        Its sample rate, Hz; must be the analysis' rate.
    path : str or path-like
        The image file to write (:func:`check_plot_path`).

    Returns
    -------
    matplotlib.figure.Figure
        The figure drawn (four panels, titled as above).

    Raises
    ------
    ParameterError
        Bad input.
    SynthError
        matplotlib is not installed (``pip install matplotlib``).
    """
    an = _analysis("analysis", analysis)
    chans = _audio_array(audio)
    fs = checks.positive("samplerate", samplerate, "Hz")
    if fs != an.samplerate:
        raise ParameterError(
            f"samplerate={samplerate!r} differs from the analysis' {an.samplerate:g} Hz")
    if an.channel is not None and an.channel >= chans.shape[1]:
        raise ParameterError(
            f"audio has {chans.shape[1]} channel(s) but the analysis used channel {an.channel}"
            f" (pass the recording with all its channels)")
    if chans.shape[0] != int(round(an.duration * fs)):
        raise ParameterError(
            f"audio has {chans.shape[0]} frames but the analysis was of "
            f"{int(round(an.duration * fs))}")
    fmt = check_plot_path(path)
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    x = chans.mean(axis=1) if an.channel is None else chans[:, an.channel]
    t = np.arange(x.size) / fs
    ticks = an.ticks
    n = np.array([tk.index for tk in ticks])

    def column(name, scale=1.0):
        return np.array([np.nan if getattr(tk, name) is None else getattr(tk, name) * scale
                         for tk in ticks])

    fig = Figure(figsize=(11, 8), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots(2, 2)
    a0 = ax[0, 0]
    a0.plot(t, x, lw=0.5, color="0.3")
    for tk in ticks:
        a0.axvline(tk.time, color="tab:red", lw=0.6, alpha=0.7)
    a0.set(xlabel="time (s)", ylabel="signal", title=f"{len(ticks)} ticks detected")

    a1 = ax[0, 1]
    a1.plot(n, column("bounce_time", 1e3), "o-", color="tab:blue", ms=3)
    a1.set(xlabel="tick", ylabel="bounce time (ms)", title="bounce time and restitution")
    a1b = a1.twinx()
    a1b.plot(n, column("restitution"), "s-", color="tab:orange", ms=3)
    a1b.set_ylabel("restitution e", color="tab:orange")

    a2 = ax[1, 0]
    energy = column("energy")
    a2.semilogy(n, energy, "o", color="tab:green", ms=4, label="tick energy")
    e = an.mean_restitution
    if e is not None and energy.size:
        a2.semilogy(n, energy[0] * (e * e) ** (n - 1.0), "--", color="0.4",
                    label=f"slope e^2, e = {e:.3f}")
    a2.set(xlabel="tick", ylabel="energy (signal units^2 s)", title="energy per tick")
    a2.legend(loc="upper right")

    a3 = ax[1, 1]
    a3.plot(n, column("centroid"), "o-", color="tab:purple", ms=3)
    a3.set(xlabel="tick", ylabel="centroid (Hz)", title="centroid and decay time")
    a3b = a3.twinx()
    a3b.plot(n, column("decay_time", 1e3), "s-", color="tab:brown", ms=3)
    a3b.set_ylabel("decay time (ms)", color="tab:brown")

    from matplotlib.ticker import MaxNLocator

    for a_ in (a1, a2, a3):
        a_.xaxis.set_major_locator(MaxNLocator(integer=True))
    fd, tmp = tempfile.mkstemp(prefix=".plot-", suffix="." + fmt, dir=folder)
    os.close(fd)
    try:
        fig.savefig(tmp, format=fmt, dpi=110)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    return fig
