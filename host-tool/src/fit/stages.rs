//! Fitting the family to one dataset ([`fit_family`]): the lattice's stages of
//! [`super::family`], members in parallel, the selection and the notes that say it.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

use brdf_core::member::{Component, Member};

use super::data::Dataset;
use super::family;
use super::family_fit::FamilyFit;
use super::goodness::{self, Goodness};
use super::member_fit::{self, GridBases, MemberFit, NotFitted};
use super::notes;
use super::offset::{self, Angles, OffsetSpec};
use super::options::{FitOptions, Residual};
use super::paper::Kind;
use super::peak;
use super::queue;
use super::select::{self, Candidate, Criterion, Selection};

/// A difference in AICc below this is not evidence for the larger model.
pub const AICC_MARGIN: f64 = select::MARGIN;

/// One member's fit and candidate, or why it could not be fitted.
type MemberResult = Result<(MemberFit, Candidate), NotFitted>;

/// Fits `members` (in parallel), each with its [`Candidate`] ([`candidate_of_member`],
/// in the same parallel pass); the results in `members`' order. The grid's unit bases
/// are evaluated once and shared by the members ([`GridBases`]).
fn fit_raw(
    bases: &GridBases<'_>,
    members: &[Member],
    residual: Residual,
    effects: bool,
) -> Vec<MemberResult> {
    // A member fitted alone, from outside the pool, has the pool to itself: its starts
    // share it. (Inside, a campaign's other sweeps keep the pool busy.)
    if let [m] = members {
        let alone = rayon::current_thread_index().is_none();
        return vec![fit_one_with(bases, *m, residual, effects, alone)];
    }
    let order = costliest_first(members);
    let fits = queue::run(
        order.len(),
        &|k| fit_one(bases, members[order[k]], residual, effects),
        &|| {},
        false,
    );
    in_members_order(&order, fits)
}

/// The indices of `members`, the costliest fits first (the most lobes, then the most
/// components): a stage lasts as long as its slowest member, so that one starts at
/// once instead of after the cheap ones queued before it (the two-lobe member with
/// every component takes about 4x any other on the paper grid).
fn costliest_first(members: &[Member]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..members.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(cost_rank(members[i])));
    order
}

/// Results taken in `order` (indices of the members), back in the members' order.
fn in_members_order(order: &[usize], fits: Vec<MemberResult>) -> Vec<MemberResult> {
    let mut fitted: Vec<(usize, MemberResult)> = order.iter().copied().zip(fits).collect();
    fitted.sort_by_key(|(i, _)| *i);
    fitted.into_iter().map(|(_, f)| f).collect()
}

/// A member's expected cost, for ordering: its lobes, then its components.
fn cost_rank(m: Member) -> (usize, usize) {
    let lobes = usize::from(m.core.is_some()) + usize::from(m.haze.is_some());
    (lobes, m.components().count())
}

/// One member's fit and candidate.
fn fit_one(bases: &GridBases<'_>, m: Member, residual: Residual, effects: bool) -> MemberResult {
    fit_one_with(bases, m, residual, effects, false)
}

/// [`fit_one`], the member `alone` ([`member_fit::fit_member_alone`]) or not.
fn fit_one_with(
    bases: &GridBases<'_>,
    m: Member,
    residual: Residual,
    effects: bool,
    alone: bool,
) -> MemberResult {
    let fit = if alone {
        member_fit::fit_member_alone(bases, m, residual)
    } else {
        member_fit::fit_member_with(bases, m, residual)
    };
    fit.map(|f| {
        let c = candidate_of_member(bases.data(), &f, residual, effects);
        (f, c)
    })
}

/// `members`' results (in their order) as fits, noting those that could not be fitted.
fn keep_fitted(
    data: &Dataset,
    members: &[Member],
    results: Vec<MemberResult>,
    notes: &mut Vec<String>,
) -> Vec<(MemberFit, Candidate)> {
    let mut out = Vec::new();
    for (m, f) in members.iter().zip(results) {
        let note = match f {
            Ok(f) => {
                out.push(f);
                continue;
            }
            Err(NotFitted::Undetermined) => format!(
                "{m}: not fitted ({} readings at {} incidence(s) cannot determine its parameters)",
                data.obs.len(),
                data.incidences.len()
            ),
            Err(NotFitted::NoStart) => format!(
                "{m}: not fitted: no start on its width grid could be refined (the model could not be evaluated there, or the optimiser failed from every one)"
            ),
        };
        // A later stage may ask for a member an earlier one could not fit: said once.
        if !notes.contains(&note) {
            notes.push(note);
        }
    }
    out
}

/// Fits every member in `members` (in parallel, those fitted ahead taken from `ahead`),
/// each with its [`Candidate`], noting those that cannot be fitted.
pub(super) fn fit_members(
    bases: &GridBases<'_>,
    members: &[Member],
    residual: Residual,
    effects: bool,
    ahead: &mut Vec<(Member, MemberResult)>,
    notes: &mut Vec<String>,
) -> Vec<(MemberFit, Candidate)> {
    let mut taken: Vec<Option<MemberResult>> = members
        .iter()
        .map(|m| {
            let i = ahead.iter().position(|(a, _)| a == m)?;
            Some(ahead.swap_remove(i).1)
        })
        .collect();
    let rest: Vec<Member> = members
        .iter()
        .zip(&taken)
        .filter(|(_, t)| t.is_none())
        .map(|(&m, _)| m)
        .collect();
    let mut fitted = fit_raw(bases, &rest, residual, effects).into_iter();
    let results = taken
        .iter_mut()
        .map(|t| {
            t.take()
                .or_else(|| fitted.next())
                .expect("one result per member")
        })
        .collect();
    keep_fitted(bases.data(), members, results, notes)
}

/// The members fitted so far, each with its candidate (its goodness computed once,
/// however often the stages select).
#[derive(Default)]
pub(super) struct Fitted {
    pub(super) members: Vec<MemberFit>,
    pub(super) cands: Vec<Candidate>,
    /// Members fitted ahead of being asked for ([`Fitted::add_first`]), by member: a
    /// later stage that asks for one takes its result from here.
    pub(super) ahead: Vec<(Member, MemberResult)>,
}

impl Fitted {
    /// Fits `members` (in parallel) and adds those that could be fitted.
    pub(super) fn add(
        &mut self,
        bases: &GridBases<'_>,
        members: &[Member],
        residual: Residual,
        notes: &mut Vec<String>,
    ) {
        self.add_with(bases, members, residual, true, notes);
    }

    /// [`Fitted::add`], with the components' effects computed only when `effects`:
    /// they are read only when a member without the component is fitted beside
    /// ([`Selection::test`]).
    pub(super) fn add_with(
        &mut self,
        bases: &GridBases<'_>,
        members: &[Member],
        residual: Residual,
        effects: bool,
        notes: &mut Vec<String>,
    ) {
        let fits = fit_members(bases, members, residual, effects, &mut self.ahead, notes);
        self.push(fits);
    }

    fn push(&mut self, fits: Vec<(MemberFit, Candidate)>) {
        for (f, c) in fits {
            self.members.push(f);
            self.cands.push(c);
        }
    }

    /// [`Fitted::add`] for the family's first batch, with the members the next stages
    /// are likely to ask for fitted ahead by threads it would leave idle. The two-lobe
    /// members take several times any other (2 ms of the paper grid's 3 on one
    /// thread): on two threads one fits them while the other fits the rest of the
    /// batch and is then idle, and the stages after fit one or two members at a time.
    /// So once the batch is fitted, every thread that comes free takes the members the
    /// stages after would fit if the selection stays where the batch puts it
    /// ([`ahead_guesses`]), one at a time. A member's fit depends on the data and the
    /// member alone, so a result taken from there is the one the stage would have
    /// made: only the time differs. On one thread nothing is fitted ahead; nor by the
    /// calling thread when it is itself one of the pool's (a campaign's sweeps keep
    /// every thread busy: a guess the stages do not ask for would be time lost).
    pub(super) fn add_first(
        &mut self,
        bases: &GridBases<'_>,
        members: &[Member],
        residual: Residual,
        notes: &mut Vec<String>,
    ) {
        if rayon::current_num_threads() < 2 {
            return self.add(bases, members, residual, notes);
        }
        // Every basis the batch uses, first, on every thread: a member would otherwise
        // wait for one another member is computing. Measured (60-80 fresh processes,
        // two runs): the family's median 4.4-4.7 -> 2.7 ms on al-0.782 and 2.3-3.0 ->
        // 2.0-2.1 on fe-0.115, its best unchanged within 3 % there (on cu-0.070 9 %
        // worse in one of two runs, 1.54 -> 1.68 ms).
        bases.prepare(members);
        let order = costliest_first(members);
        let n = order.len();
        let cells: Vec<OnceLock<MemberResult>> = (0..n).map(|_| OnceLock::new()).collect();
        let left = AtomicUsize::new(n);
        let guesses: Mutex<Guesses> = Mutex::new(Guesses::default());
        let ahead: Mutex<Vec<(Member, MemberResult)>> = Mutex::new(Vec::new());
        let done = || -> Vec<&MemberResult> { cells.iter().filter_map(OnceLock::get).collect() };
        let first = |k: usize| {
            let _ = cells[k].set(fit_one(bases, members[order[k]], residual, true));
            // The last of the batch to end: the guesses from the whole batch.
            if left.fetch_sub(1, Ordering::AcqRel) == 1 {
                lock(&guesses).settle(next_guesses(&done(), members));
            }
        };
        let here = rayon::current_thread_index().is_none();
        let then = || {
            // The first thread here guesses from the fits ended so far (the two-lobe
            // members may still be running); the batch's last fit replaces these
            // guesses with those of the whole batch.
            loop {
                let m = {
                    let mut g = lock(&guesses);
                    if g.list.is_none() {
                        g.list = Some(ahead_guesses(&done(), members));
                    }
                    match g.take() {
                        Some(m) => m,
                        None => return,
                    }
                };
                // A smooth-k_s guess whose member with k_s per incidence is still being
                // fitted comes last in the list: with nothing else left, a thread of a
                // fit that has the pool to itself fits it at once rather than wait idle
                // (on al-0.782 one thread waited 0.2 ms of the family's 2.7 for the
                // Student-t member, then fitted its smooth variant alone); wasted only
                // when the variant turns out bounded out. In a campaign (`here` false:
                // the other sweeps' fits wait for the threads) it waits.
                match needed_ahead(m, &cells, &ahead).or(here.then_some(true)) {
                    Some(true) => {
                        let r = fit_one(bases, m, residual, true);
                        lock(&ahead).push((m, r));
                        lock(&guesses).fitted(m);
                    }
                    Some(false) => {}
                    None => lock(&guesses).wait(m),
                }
            }
        };
        queue::run(n, &|k| first(k), &then, here);
        let fits: Vec<MemberResult> = cells
            .into_iter()
            .map(|c| c.into_inner().expect("every member was fitted"))
            .collect();
        let results = in_members_order(&order, fits);
        let fits = keep_fitted(bases.data(), members, results, notes);
        self.push(fits);
        self.ahead = ahead.into_inner().unwrap_or_else(|e| e.into_inner());
    }

    /// The member selected by AICc so far.
    pub(super) fn best(&self) -> Option<Member> {
        Selection::new(&self.cands, Criterion::Aicc)
            .best()
            .map(|c| c.member)
    }
}

/// The family's second stage: the variants `more` of the selected component set. A
/// smooth-k_s variant is fitted only when it could be selected
/// ([`family::smooth_needed`]): those whose member with k_s per incidence is among
/// `more` wait for its fit, the rest are fitted beside the others. The fits are kept
/// in the order of `more`.
pub(super) fn stage_two(
    fitted: &mut Fitted,
    bases: &GridBases<'_>,
    more: &[Member],
    residual: Residual,
    notes: &mut Vec<String>,
) {
    use family::SmoothVariant;
    let start = fitted.members.len();
    let mut later = Vec::new();
    for pass in 0..2 {
        let (asked, pending): (&[Member], &[Member]) = if pass == 0 {
            (more, more)
        } else {
            (&later, &[])
        };
        let mut now = Vec::new();
        let mut deferred = Vec::new();
        for &m in asked {
            match family::smooth_needed(m, &fitted.members, &fitted.cands, pending) {
                SmoothVariant::Needed => now.push(m),
                SmoothVariant::Deferred => deferred.push(m),
                SmoothVariant::Bounded { by, aicc_above } => notes.push(format!(
                    "{m}: not fitted: a smooth k_s is one choice of k_s per incidence, so it fits no better than {by}, whose fit puts its AICc at least {aicc_above:.1} above the selected member's (and its BIC above too)"
                )),
            }
        }
        fitted.add(bases, &now, residual, notes);
        later = deferred;
    }
    // In the order of `more`, whichever batch each was fitted in.
    let order = |f: &MemberFit| more.iter().position(|&m| m == f.member());
    let mut tail: Vec<(MemberFit, Candidate)> = fitted
        .members
        .drain(start..)
        .zip(fitted.cands.drain(start..))
        .collect();
    tail.sort_by_key(|(f, _)| order(f));
    for (f, c) in tail {
        fitted.members.push(f);
        fitted.cands.push(c);
    }
}

/// The family's first stage: [`family::default_members`], then the reference members
/// the decision needs ([`family::needed`]: one component from the selection, or
/// possibly better than it) until none is. Returns the fits, in the lattice's order,
/// and every member tried (fitted or not).
pub(super) fn stage_one(
    bases: &GridBases<'_>,
    residual: Residual,
    notes: &mut Vec<String>,
) -> (Fitted, Vec<Member>) {
    let mut tried = family::default_members();
    let mut fitted = Fitted::default();
    fitted.add_first(bases, &tried, residual, notes);
    loop {
        let more = family::needed(&fitted.members, &fitted.cands, &tried);
        if more.is_empty() {
            break;
        }
        tried.extend(&more);
        fitted.add(bases, &more, residual, notes);
    }
    let order = family::reference_members();
    let mut both: Vec<(MemberFit, Candidate)> =
        fitted.members.into_iter().zip(fitted.cands).collect();
    both.sort_by_key(|(f, _)| order.iter().position(|&m| m == f.member()));
    let (members, cands) = both.into_iter().unzip();
    let ahead = fitted.ahead;
    (
        Fitted {
            members,
            cands,
            ahead,
        },
        tried,
    )
}

/// Fits the family and selects a member: the default family (three stages, see
/// [`family`]) unless [`FitOptions::members`] names exactly the members to fit. With
/// [`FitOptions::offset`], at the instrument's angles given or fitted
/// ([`super::offset`]): the family is fitted to the readings at the sample's local
/// angles, and [`FamilyFit::angles`] says which.
pub fn fit_family(data: &Dataset, opts: &FitOptions) -> Result<FamilyFit, String> {
    let Some(spec) = opts.offset.or(data.offset) else {
        return fit_nominal(data, opts);
    };
    let t0 = Instant::now();
    let plain = FitOptions {
        offset: None,
        ..opts.clone()
    };
    let angles = match spec {
        OffsetSpec::Detector(d) => Angles::given(d),
        OffsetSpec::Fit => {
            let first = fit_nominal(data, &plain)?;
            let m = first.selected_member;
            let s0 = first
                .fitted(data, m)
                .and_then(|v| peak::mean_offset(data, &v))
                .map_or(0.0, |(mean, _)| mean);
            offset::fit_angles(data, m, &member_ssr(&plain, m), plain.residual, s0)
        }
    };
    let (local, _) = angles.apply(data)?;
    let mut fam = fit_nominal(&local, &plain)?;
    let mut notes = angles.notes();
    notes.append(&mut fam.notes);
    fam.notes = notes;
    fam.angles = Some(angles);
    fam.fit_seconds = t0.elapsed().as_secs_f64();
    Ok(fam)
}

/// `member` fitted to readings as [`fit_family`] fits it (options `opts`, offsets
/// aside): its SSR and residual degrees of freedom; what [`offset::fit_angles`]
/// minimises.
pub(super) fn member_ssr(
    opts: &FitOptions,
    member: Member,
) -> impl Fn(&Dataset) -> Option<(f64, usize)> + Sync {
    let one = FitOptions {
        members: Some(vec![member]),
        offset: None,
        ..opts.clone()
    };
    move |data: &Dataset| {
        let f = fit_nominal(data, &one).ok()?;
        f.member(member).map(|m| (m.ssr, m.n - m.k()))
    }
}

/// [`fit_family`] at the readings' own angles.
fn fit_nominal(data: &Dataset, opts: &FitOptions) -> Result<FamilyFit, String> {
    let t0 = Instant::now();
    // The objective's noise model, from the data where it is to be: once, so that
    // every member, the criteria and the notes share it.
    let resolved = FitOptions {
        residual: opts.residual.resolved(data),
        ..opts.clone()
    };
    let opts = &resolved;
    let aperture = opts.aperture.or(data.aperture);
    let requested: Option<Vec<Member>> = opts.members.clone();
    let mut notes = Vec::new();
    let mut bases = GridBases::new(data, aperture);
    bases.refine_all_starts(opts.all_starts);
    bases.hold(opts.fixed);
    bases.set_loss(opts.loss);
    let mut fitted = if let Some(listed) = &requested {
        let mut fitted = Fitted::default();
        // One member alone is tested against no other: its effects would go unread.
        fitted.add_with(&bases, listed, opts.residual, listed.len() > 1, &mut notes);
        fitted
    } else {
        let (mut fitted, tried) = stage_one(&bases, opts.residual, &mut notes);
        // Stage two: the selected component set's lobe variants (GGX, Student-t, smooth k_s).
        if let Some(best) = fitted.best() {
            let more: Vec<Member> = family::variants_of(best)
                .into_iter()
                .filter(|m| !tried.contains(m))
                .collect();
            bases.retain_for(&more);
            stage_two(&mut fitted, &bases, &more, opts.residual, &mut notes);
        }
        // Stage three: the selected member's haze with the other distributions.
        if let Some(best) = fitted.best() {
            let more: Vec<Member> = family::haze_variants_of(best)
                .into_iter()
                .filter(|m| !fitted.members.iter().any(|f| f.member() == *m))
                .collect();
            bases.retain_for(&more);
            fitted.add(&bases, &more, opts.residual, &mut notes);
        }
        untested_components(&mut fitted, &mut bases, opts.residual, &mut notes);
        fitted
    };
    let fit_seconds = t0.elapsed().as_secs_f64();
    let Fitted {
        members,
        cands: candidates,
        ..
    } = std::mem::take(&mut fitted);
    let sel = Selection::new(&candidates, Criterion::Aicc);
    let selected_member = sel
        .best()
        .map(|c| c.member)
        .ok_or("no model could be fitted to these data")?;
    let selected = sel.best_paper().unwrap_or(Kind::IdealDiffuse);
    let selected_bic = Selection::new(&candidates, Criterion::Bic)
        .best()
        .map_or(selected_member, |c| c.member);
    let notes = notes::family_notes(
        data,
        &members,
        &candidates,
        selected_member,
        selected_bic,
        std::mem::take(&mut notes),
        super::options::Compared {
            residual: opts.residual,
            loss: opts.loss,
            aperture,
        },
    );
    Ok(FamilyFit {
        incidences: data.incidences.clone(),
        members,
        candidates,
        selected_member,
        selected,
        selected_bic,
        notes,
        fit_seconds,
        rmse_nearest: (0..data.incidences.len())
            .map(|j| match data.specular_reference(j) {
                Some((k, false)) => Some(data.obs[k].theta_r),
                _ => None,
            })
            .collect(),
        aperture,
        aperture_assumed: false,
        has_noise: data.has_noise(),
        units: data.units,
        checks: opts.checks,
        physical: Vec::new(),
        angles: None,
    })
}

/// The selected member without each of its components that no fit has tested yet
/// (the member without it, or its reference member's, not fitted), and with each
/// component it lacks whose addition no fit has tested: fitted, so that every
/// component the selection keeps or leaves out is backed by a comparison the report
/// names (the ideal diffuse of a GGX member was "on, not tested" on every real sweep,
/// MERL aluminium's directional diffuse "absent (not tested)"). Repeated while the
/// selection moves to a member with an untested component (at most three rounds).
fn untested_components(
    fitted: &mut Fitted,
    bases: &mut GridBases<'_>,
    residual: Residual,
    notes: &mut Vec<String>,
) {
    // Tried in an earlier round: one that could not be fitted is not tried again (its
    // note is made once).
    let mut tried: Vec<Member> = Vec::new();
    for _ in 0..3 {
        let Some(sel) = fitted.best() else {
            return;
        };
        let s = Selection::new(&fitted.cands, Criterion::Aicc);
        let mut more: Vec<Member> = Vec::new();
        for m in untested(&s, sel)
            .into_iter()
            .chain(untested_additions(&s, sel))
        {
            if !more.contains(&m)
                && !tried.contains(&m)
                && !fitted.members.iter().any(|f| f.member() == m)
            {
                more.push(m);
            }
        }
        if more.is_empty() {
            return;
        }
        bases.retain_for(&more);
        fitted.add(bases, &more, residual, notes);
        tried.extend(more);
    }
}

/// `sel` without each of its components that no fit in `s` tests yet (the valid ones):
/// what [`untested_components`] fits, and [`ahead_guesses`] guesses.
fn untested(s: &Selection<'_>, sel: Member) -> Vec<Member> {
    sel.components()
        .filter(|&c| s.test(sel, c).is_none())
        .map(|c| sel.without(c))
        .filter(|m| m.is_valid())
        .collect()
}

/// `sel` with each component it lacks (the valid members; ABg is no component to
/// add) whose addition no fit in `s` tests yet: what the notes would call "absent
/// (not tested)".
fn untested_additions(s: &Selection<'_>, sel: Member) -> Vec<Member> {
    Component::ALL
        .into_iter()
        .filter(|&c| c != Component::Abg)
        .filter_map(|c| select::with(sel, c).filter(|&m| s.test(m, c).is_none()))
        .collect()
}

/// The members to fit ahead ([`Fitted::add_first`]) and those taken so far.
#[derive(Default)]
struct Guesses {
    /// The guesses, once made ([`ahead_guesses`]).
    list: Option<Vec<Member>>,
    /// Those taken (fitted or skipped), in any list so far.
    taken: Vec<Member>,
    /// Smooth-k_s guesses waiting for their member with k_s per incidence, which a
    /// thread is fitting ahead: the thread that ends it takes them up again.
    waiting: Vec<Member>,
}

impl Guesses {
    /// The next guess not taken yet, now taken.
    fn take(&mut self) -> Option<Member> {
        let m = *self
            .list
            .as_ref()?
            .iter()
            .find(|m| !self.taken.contains(m))?;
        self.taken.push(m);
        Some(m)
    }

    /// `m` waits for its member with k_s per incidence to be fitted.
    fn wait(&mut self, m: Member) {
        self.waiting.push(m);
    }

    /// `m` was fitted ahead: the guesses that waited for it can be taken again.
    fn fitted(&mut self, m: Member) {
        let ready = |w: &Member| family::per_incidence_of(*w) == Some(m);
        self.taken
            .retain(|t| !(self.waiting.contains(t) && ready(t)));
        self.waiting.retain(|w| !ready(w));
    }

    /// The guesses from the whole first batch, in place of any made before.
    fn settle(&mut self, list: Vec<Member>) {
        self.list = Some(list);
    }
}

/// The mutex's value, whether or not a thread panicked holding it.
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Whether to fit the guess `m` ahead: yes, but for a smooth-k_s variant only when
/// its member with k_s per incidence, fitted (in the first batch, `first`, or ahead),
/// does not bound it out of the selection ([`family::smooth_needed`]); `None` while
/// that member is not fitted yet.
fn needed_ahead(
    m: Member,
    first: &[OnceLock<MemberResult>],
    ahead: &Mutex<Vec<(Member, MemberResult)>>,
) -> Option<bool> {
    let Some(by) = family::per_incidence_of(m) else {
        return Some(true);
    };
    let done = lock(ahead);
    let fits = || {
        first
            .iter()
            .filter_map(OnceLock::get)
            .chain(done.iter().map(|(_, r)| r))
            .filter_map(|r| r.as_ref().ok())
    };
    let cands: Vec<Candidate> = fits().map(|(_, c)| c.clone()).collect();
    let (f, _) = fits().find(|(f, _)| f.member() == by)?;
    Some(
        family::smooth_needed(m, std::slice::from_ref(f), &cands, &[])
            == family::SmoothVariant::Needed,
    )
}

/// The members to fit ahead once every fit of the first batch (`fits`) has ended: the
/// reference members the first stage goes on to fit ([`family::needed`]:
/// they can move the selection, as the solar array's member without its directional
/// diffuse does), or when there is none, [`ahead_guesses`]. Guesses made for a
/// selection that then moves were 34 ms of lost work on the solar array (five members,
/// none asked for).
fn next_guesses(fits: &[&MemberResult], tried: &[Member]) -> Vec<Member> {
    let (f, c): (Vec<MemberFit>, Vec<Candidate>) =
        fits.iter().filter_map(|r| r.as_ref().ok()).cloned().unzip();
    let needed = family::needed(&f, &c, tried);
    if needed.is_empty() {
        ahead_guesses(fits, tried)
    } else {
        needed
    }
}

/// The members the stages after the first would fit if the best of `fits` (the first
/// batch, or as much of it as has ended) stays selected, most likely first: its lobe
/// variants ([`family::variants_of`]) with k_s per incidence, itself without each of
/// its components no fit tests yet ([`untested_components`]), then the smooth-k_s
/// variants ([`needed_ahead`]: fitted only when they could be selected, or, when the
/// fit has the pool to itself, while that is not known yet). None already in `tried`.
fn ahead_guesses(fits: &[&MemberResult], tried: &[Member]) -> Vec<Member> {
    let cands: Vec<Candidate> = fits
        .iter()
        .filter_map(|f| f.as_ref().ok().map(|(_, c)| c.clone()))
        .collect();
    let sel = Selection::new(&cands, Criterion::Aicc);
    let Some(best) = sel.best().map(|c| c.member) else {
        return Vec::new();
    };
    let (smooth, per_incidence): (Vec<Member>, Vec<Member>) = family::variants_of(best)
        .into_iter()
        .partition(|&m| family::per_incidence_of(m).is_some());
    let without = untested(&sel, best);
    let mut out: Vec<Member> = Vec::new();
    for m in per_incidence.into_iter().chain(without).chain(smooth) {
        if !tried.contains(&m) && !out.contains(&m) {
            out.push(m);
        }
    }
    out
}

/// One fit's [`Candidate`]: its goodness and its components' effects.
fn candidate_of_member(
    data: &Dataset,
    f: &MemberFit,
    residual: Residual,
    effects: bool,
) -> Candidate {
    // The fit's own sum of squares: its residuals are those of its fitted values
    // (`goodness::member_fitted`), summed by incidence.
    let g: Option<Goodness> = goodness::goodness_of_ssr(data, f.ssr, residual, f.k());
    let effect = if effects {
        goodness::component_effects(f, data, residual)
    } else {
        [None; Component::ALL.len()]
    };
    Candidate::of_member(f, g, effect)
}
