"""A diagnosis in words: the causes' values and sentences, the lines ``backlash-df diagnose`` prints, the report.

Rendered from a :class:`~backlash_df.identify.diagnose.Diagnosis` and its
:class:`~backlash_df.identify.diagnose.Cause` and
:class:`~backlash_df.identify.diagnose.Stage` objects (their fitted parameters,
fits and flags), and from the records of why the search decided as it did
(:mod:`backlash_df.identify.reasons`): each candidate's reason
(:func:`reason_sentence`) and the warnings (:func:`warning_sentence`), each read by
its rule's name.  The figures are drawn by the results and handed in.
Values print as fitted, except in the report's parameter table, where a value the
fit does not resolve prints as 0 (:func:`parameter_resolution`).
"""

import html
import math

from .html import below_text, figure_html, html_page, percent_text, rig_sections, table_html

__all__ = ["FAR_BELOW_INTERVAL", "FIT_RESOLUTION", "parameter_resolution", "reason_sentence", "warning_sentence",
           "diagnosis_sentences", "diagnosis_report"]

#: What a cause's gain is, in the words the terminal and the report print.
GAIN_DEFINITION = ("the share of the validation residual sum of squares (k-step or 0.4 s ahead, whichever passes "
                   "the significance rule) the effect removes from the model it is added to")
#: What the validation fit percentages are, in the words the terminal prints.
FIT_DEFINITION = ("100 (1 - |y - y_pred| / |y - mean y|) % per speed over the validation part, as MATLAB's compare: "
                  "k-step from each segment's measured start, 0.4 s ahead, free run from the part's start; below 0 "
                  "where the prediction strays farther from the data than their mean, as a free run of a model that "
                  "lacks the data's friction does")
#: A fitted value within this share of its own 95 % interval's half-width prints as 0 (:func:`parameter_resolution`).
FAR_BELOW_INTERVAL = 1e-3
#: The fit's resolution as a share of the range it allows (:func:`parameter_resolution`).
FIT_RESOLUTION = 1e-8


# --------------------------------------------------------------------------- values


def parameter_resolution(parameter):
    """The smallest magnitude of a fitted value the diagnosis report prints: below it the value prints as 0.

    The rule, for the report's rendering only (the JSON, the objects and the terminal
    keep every number as fitted): a fitted value prints as 0 where its magnitude is at
    most

    - :data:`FAR_BELOW_INTERVAL` (1e-3) times its own 95 % interval's half-width: the
      data cannot tell it from 0, and the digits printed beside the interval would be
      those of where the solver stopped, not of the data (a motor-side Coulomb friction
      of 4.451e-10 N m, 95 % CI -0.3487 .. 0.3487 N m, prints as 0); or
    - :data:`FIT_RESOLUTION` (1e-8) times the range the fit allows (its bounds' width):
      the relative step at which the trust-region solver stops (scipy's
      ``least_squares`` ``xtol``), the finest the fit resolves whatever the interval
      (an actuator delay of 3.5e-12 s fitted within [0, 0.05] s prints as 0).

    A value the rule keeps prints as fitted, to the digits the table shows.  The
    interval and the standard error always print as computed.

    Parameters
    ----------
    parameter : FitParameter

    Returns
    -------
    float
        The resolution, the parameter's unit; 0 where neither the interval nor the
        bounds are finite.
    """
    low, high = parameter.ci95
    half_width = 0.5 * (high - low)
    width = parameter.upper - parameter.lower
    return max(FAR_BELOW_INTERVAL * half_width if math.isfinite(half_width) else 0.0,
               FIT_RESOLUTION * width if math.isfinite(width) else 0.0)


def shown_value(parameter):
    """The parameter's value as the report prints it: 0.0 at or below :func:`parameter_resolution`."""
    return 0.0 if abs(parameter.value) <= parameter_resolution(parameter) else float(parameter.value)


def effects_name(candidate):
    """A candidate model by its effects (``rubber + torque_offset``; ``none`` for the baseline)."""
    return " + ".join(candidate.effects) or "none"


def parameter_text(parameter):
    """An added parameter in the report's search table: ``name = value (low .. high) unit``, the value as
    :func:`shown_value` prints it; ``-`` for none."""
    if parameter is None:
        return "-"
    low, high = parameter.ci95
    return f"{parameter.name} = {shown_value(parameter):.4g} ({low:.4g} .. {high:.4g}) {parameter.unit}"


# --------------------------------------------------------------------------- causes


def value_text(cause, name):
    """Parameter ``name`` of a cause as printed: ``value unit (95 % CI low .. high)``; ``not determined`` for the
    value where the cause is not ``determined``, and the fit's range for the interval where it is ``on_bound``."""
    p = cause.parameters[name]
    if cause.on_bound:
        return (f"not determined: on the bound of the fit's range, {p.value:.4g} {p.unit} "
                f"({p.lower:.4g} .. {p.upper:.4g})")
    value = f"{p.value:.4g}" if cause.determined else "not determined"
    return f"{value} {p.unit} (95 % CI {p.ci95[0]:.4g} .. {p.ci95[1]:.4g})"


def cause_summary(cause):
    """``effect (side): value unit (95 % CI low .. high)`` (:func:`value_text`), the side left out on the rigid
    body (one inertia)."""
    side = f" ({cause.side} side)" if cause.side and cause.structure != "rigid_body" else ""
    return f"{cause.effect}{side}: {value_text(cause, cause.effect)}"


def cause_sentence(cause, described):
    """A cause in a sentence a person can act on, or, where its value is not determined, that the drive has it
    but the record does not determine its size, and why.

    Parameters
    ----------
    cause : Cause
    described : str or None
        The catalogue's sentence of a determined cause at its value
        (:meth:`~backlash_df.identify.effects.Effect.describe`); None where the cause is not determined.

    Returns
    -------
    str
    """
    parameter = cause.parameters[cause.effect]
    if cause.determined:
        if cause.stribeck_speed is None:
            return described
        return (f"{described} Its Stribeck speed w_s is {cause.stribeck_speed:.3g} rad/s; the size holds for that "
                f"w_s in -F_s exp(-(w/w_s)^2) sign(w).")
    why = (f"the fit ends on the bound of the range it allows ({parameter.value:.4g} {parameter.unit}) and asks "
           f"for a value beyond it, so the value is a bound, not an estimate; the effect may stand in for "
           f"something outside the catalogue" if cause.on_bound
           else "the rigid-body and the two-mass model disagree beyond their intervals")
    return (f"The drive has {cause.effect.replace('_', ' ')}, but this record does not determine its size: "
            f"{why} (see the warnings).")


def _cause_list(causes):
    """``rubber, coulomb_friction (load side)``; ``none``."""
    return ", ".join(c.effect + (f" ({c.side} side)" if c.side else "") for c in causes) or "none"


# --------------------------------------------------------------------------- sentences


def skew_sentence(skew, shown, share):
    """An encoder skew in words.

    Parameters
    ----------
    skew : FitParameter
        How much later the load encoder is read than the motor encoder, s.
    shown : bool
        Whether the record shows it (its interval excludes zero and its twist is at least ``share`` of the
        measured twist's spread).
    share : float
        That smallest share (:data:`~backlash_df.identify.diagnose.MIN_SKEW_SHARE`).

    Returns
    -------
    str
    """
    low, high = (1e3 * value for value in skew.ci95)
    if shown:
        return (f"The load encoder is read {1e3 * skew.value:.3g} ms (95 % CI {low:.3g} to {high:.3g} ms) later "
                f"than the motor encoder: the measured twist holds that time the load speed, removed before "
                f"any fit.")
    return (f"No encoder skew shows ({1e3 * skew.value:.2g} ms, 95 % CI {low:.2g} to {high:.2g} ms: its interval "
            f"holds zero, or its twist is below {100 * share:g} % of the measured twist's spread): the "
            f"twist is taken as measured.")


def resolution_sentence(shaft, measurements):
    """Which model names the causes, and why (the shaft's mode against the band the record resolves).

    Parameters
    ----------
    shaft : ShaftResolution
    measurements : Measurements
        The record (whether it holds the twist).

    Returns
    -------
    str
    """
    mode, band = f"{shaft.mode_frequency:.3g} Hz", f"{shaft.resolved_frequency:.3g} Hz"
    if shaft.resolved:
        return (f"The record resolves the shaft's mode ({mode} from the rig file, inside the {band} band in which "
                f"the motor speed rises above its noise): the causes are named from the two-mass model, the "
                f"rigid-body model is reported beside it.")
    start = (" (without angle columns its segments start on the rigid body's state)"
             if getattr(measurements, "twist", None) is None else "")
    return (f"The record does not resolve the shaft's mode ({mode} from the rig file, above the {band} up to which "
            f"the motor speed rises above its noise): the drive moves as one rigid body here, so the causes are "
            f"named from the rigid-body model, with the two-mass model{start} as the cross-check.")


def disagreement_note(disagreement):
    """Both models' fits of an effect whose 95 % intervals do not overlap, in a sentence (a diagnosis' warning).

    Parameters
    ----------
    disagreement : Disagreement
        Its ``effect`` and each model's entry ``two_mass``, ``rigid_body``: ``{"value", "ci95", "unit"}``
        (:class:`~backlash_df.identify.reasons.Disagreement`).

    Returns
    -------
    str
    """
    name, rigid, two_mass = disagreement.effect, disagreement.rigid_body, disagreement.two_mass
    return (f"{name}: the rigid-body model gives {rigid['value']:.4g} ({rigid['ci95'][0]:.4g} .. {rigid['ci95'][1]:.4g}) "
            f"{rigid['unit']}, the two-mass model {two_mass['value']:.4g} ({two_mass['ci95'][0]:.4g} .. "
            f"{two_mass['ci95'][1]:.4g}) {two_mass['unit']}: they disagree beyond their 95 % intervals, so no value "
            f"is named; the record does not determine it")


# --------------------------------------------------------------------------- a candidate's reason


def _torque_check(finding):
    return (f"its torque {finding.shown:.3g} N m is below {100 * finding.share:g} % of the record's RMS torque "
            f"{finding.reference:.3g} N m")


def _twist_check(finding):
    return (f"beta {finding.value:.3g} rad is within the twist's uncertainty {finding.limit:.3g} rad"
            + ("" if finding.twist_measured else " (integrated from the speeds: record motor_angle and load_angle)"))


#: A failed check in words, by its rule (:class:`~backlash_df.identify.reasons.Check`).
_FAILED = {
    "gain": lambda f: f"gain {percent_text(f.value)} % ({f.mode}) below {100 * f.limit:g} %",
    "t statistic": lambda f: f"t {below_text(f.value, f.limit)} ({f.mode}) below {f.limit:g}",
    "interval": lambda f: f"95 % CI includes {f.limit:g}",
    "delay": lambda f: "delay shorter than one sample",
    "torque": _torque_check,
    "rubber share": lambda f: (f"beta {f.value:.3g} rad is below {100 * f.share:g} % of the half gap "
                               f"{f.reference:.3g} rad"),
    "rubber twist": _twist_check,
}
_STEP_WORDS = {"screening": "screening: ", "backward check": "backward check: ", "forward": ""}


def reason_sentence(reason):
    """Why a candidate was accepted or not, in the words of the search table, from its record.

    Parameters
    ----------
    reason : Reason
        The step that judged the candidate and its findings (:class:`~backlash_df.identify.reasons.Reason`).

    Returns
    -------
    str
        ``the nominal structure (reference)``; the failed checks joined by ``; `` (``after the free-run
        refinement: ...; dropped`` after the refinement), or, where every check passed, the gain, t and
        interval that passed; a screening or backward check says so first.
    """
    if reason.step == "reference":
        return "the nominal structure (reference)"
    failed = "; ".join(_FAILED[str(finding.rule)](finding) for finding in reason.findings if not finding.passed)
    if reason.step == "refinement":
        return f"after the free-run refinement: {failed}; dropped"
    if not failed:
        gain, t, interval = (next(f for f in reason.findings if f.rule == rule)
                             for rule in ("gain", "t statistic", "interval"))
        failed = f"gain {percent_text(gain.value)} % ({gain.mode}), t {t.value:.1f}, CI excludes {interval.limit:g}"
    return _STEP_WORDS[str(reason.step)] + failed


# --------------------------------------------------------------------------- warnings


def _weak_baseline(caveat):
    return (f"the baseline explains too little of the validation data (k-step fit {caveat.fit:.1f} % on a speed, "
            f"below {caveat.minimum:g} %): no cause is named; check the rig file (inertias, stiffness, gear ratio, "
            f"units) and the record")


def _unexplained(caveat):
    return (f"the named causes leave much of the data unexplained: with the named causes the model still predicts "
            f"{caveat.speed} {caveat.horizon:g} s ahead only to {caveat.fit:.1f} % (below {caveat.minimum:g} %); "
            f"something outside the catalogue remains (a pose-dependent gravity torque or inertia, a feed-forward, a "
            f"torque the record does not hold), and the named values absorb part of it")


def _few_segments(caveat):
    of = f" of {caveat.samples} samples" if caveat.samples else ""
    return (f"the estimation part holds only {caveat.segments} independent segments{of} (fewer than "
            f"{caveat.minimum}): cluster-robust intervals over so few segments are too narrow, and so short a record "
            f"may not show enough of the motion to tell effects apart; record longer")


def _unphysical(caveat):
    low, high = caveat.ci95
    return (f"the 95 % interval of {caveat.name} includes unphysical negative values ({low:.4g} .. {high:.4g} "
            f"{caveat.unit})")


def _on_bound(caveat):
    several = len(caveat.values) > 1
    hint = (" (values of the shaft a record cannot determine where it does not resolve the shaft's mode: the "
            "causes are then named from the rigid-body model, which does not use them; elsewhere, check them in "
            "the rig file)" if caveat.plant else "")
    return (f"{'these values end' if several else 'this value ends'} on a bound of the range the fit allows, so the "
            f"data do not determine {'them' if several else 'it'}{hint}: "
            + "; ".join(f"{v.name} = {v.value:.4g} {v.unit} (range [{v.lower:.4g}, {v.upper:.4g}])"
                        for v in caveat.values))


def _initial_speed(caveat):
    return (f"the fitted initial {caveat.name[:-1].replace('_', ' ')} {caveat.fitted:.4g} rad/s contradicts the "
            f"measured {caveat.measured:.4g} rad/s")


def _absorbed(caveat):
    (low, high), (dropped_low, dropped_high) = caveat.kept_ci95, caveat.dropped_ci95
    return (f"{caveat.kept} absorbs {caveat.dropped}: fitted together on the estimation part they are "
            f"{caveat.kept_value:.4g} ({low:.4g} .. {high:.4g}) {caveat.kept_unit} and {caveat.dropped_value:.4g} "
            f"({dropped_low:.4g} .. {dropped_high:.4g}) {caveat.dropped_unit}, but {caveat.dropped} does not improve "
            f"the validation part enough to be named, and without it {caveat.kept} is {caveat.kept_alone:.4g} "
            f"{caveat.kept_unit}: this record does not tell the two apart (a longer record, or one whose speed "
            f"covers a wider range, would)")


def _side(caveat):
    return (f"the side of {caveat.effect} is not determined by the data: on its own it explains the validation data "
            f"as well on the {caveat.other_side} side (gain {100 * caveat.other_gain:.1f} % against "
            f"{100 * caveat.gain:.1f} %); the shaft is too stiff here to tell the sides apart")


#: A warning in words, by its concern (:class:`~backlash_df.identify.reasons.Concern`).
_WARNINGS = {
    "record": lambda caveat: caveat.text, "weak baseline": _weak_baseline, "unexplained": _unexplained,
    "few segments": _few_segments, "unphysical interval": _unphysical, "on bound": _on_bound,
    "initial speed": _initial_speed, "absorbed": _absorbed, "side": _side, "disagreement": disagreement_note,
}


def warning_sentence(caveat, *, stage_named=False):
    """A diagnosis' warning in words, from its record.

    Parameters
    ----------
    caveat : RecordNote, WeakBaseline, ...
        The concern and its numbers (a record of :mod:`backlash_df.identify.reasons`).
    stage_named : bool
        Whether to say ``rigid-body model:`` first where the warning concerns the rigid-body stage's values
        (a diagnosis' warnings name it; the stage's own do not).

    Returns
    -------
    str
    """
    text = _WARNINGS[str(caveat.rule)](caveat)
    return f"rigid-body model: {text}" if stage_named and caveat.structure == "rigid_body" else text


def prediction_mode_text(mode):
    """How a diagnosis' fit numbers were computed, from the k-step prediction's ``mode``."""
    return (f"{mode}: each segment simulated from the data's state, driven by the "
            f"measured torques; free run: one simulation from the data's state at the validation start; "
            f"both scored on the validation part only")


def diagnosis_sentence(answer, causes, shaft, measurements, horizon):
    """The answer in sentences: which model names the causes (where it is the rigid body), each cause's action,
    absorbed and undetermined values, what is left unexplained, and the validation fit.

    Parameters
    ----------
    answer : Stage
        The stage whose causes are named (its fits, ``absorbed``, ``weak_baseline``, ``unexplained`` and
        ``nominal_values``).
    causes : list of Cause
        The causes named, ``determined`` as the cross-check left them.
    shaft : ShaftResolution
    measurements : Measurements
    horizon : float
        The ahead prediction's horizon, s (:data:`~backlash_df.identify.diagnose.VALIDATION_HORIZON`).

    Returns
    -------
    str
    """
    baseline, extended, rigid = answer.baseline, answer.extended, answer.structure == "rigid_body"
    gain = (f" Validation fit (mean over the speeds{', rigid-body model' if rigid else ''}): k-step "
            f"{baseline.mean_fit_percent:.1f} % -> {extended.mean_fit_percent:.1f} %, {horizon:g} s ahead "
            f"{baseline.mean_ahead_fit_percent:.1f} % -> {extended.mean_ahead_fit_percent:.1f} %.")
    sentences = [resolution_sentence(shaft, measurements)] if rigid else []
    if not causes:
        if answer.weak_baseline:
            sentences.append("No cause named: the nominal model explains too little of the data to attribute the rest.")
            return " ".join(sentences) + gain
        sentences.append("No effect of the catalogue improves the prediction of the validation part enough to be "
                         "named: the nominal model is the best supported, calibrated "
                         + ", ".join(f"{name} = {value:.4g}" for name, value in answer.nominal_values.items())
                         + "; an effect smaller than this record's noise and length can show may still be present.")
        return " ".join(sentences) + gain
    sentences += [cause.describe() for cause in causes]
    if answer.absorbed:
        pairs = "; ".join(f"{kept} absorbs {dropped}" for kept, dropped, _ in answer.absorbed)
        sentences.append(f"Not separated from another effect by this record ({pairs}; see the warnings): the "
                         f"named value holds both.")
    if answer.unexplained:
        sentences.append("These causes are the catalogue's best approximation, not the whole explanation: "
                         "the extended model still misses much of the data (see the warnings).")
    return " ".join(sentences) + gain


def _fit_line(structure, model):
    """``validation fit, two-mass rubber: motor_speed 98.9 % k-step / 99.2 % ahead / 99.3 % free run, ...``."""
    label = " + ".join(model.effects) or "baseline (no effect)"
    fits = ", ".join(f"{name} {model.fit_percent[name]:.1f} % k-step / {model.ahead_fit_percent[name]:.1f} % "
                     f"ahead / {model.free_run_fit_percent[name]:.1f} % free run" for name in model.fit_percent)
    return f"validation fit, {structure} {label}: {fits}"


def diagnosis_sentences(diagnosis):
    """The lines ``backlash-df diagnose`` prints: the cause, each named value, what each model names, the answer's
    sentence, the encoder skew, the validation fits, the warnings.

    Parameters
    ----------
    diagnosis : Diagnosis

    Returns
    -------
    list of str
    """
    shaft = diagnosis.shaft
    lines = [f"cause: {diagnosis.cause} (from the {diagnosis.structure.replace('_', '-')} model; shaft mode "
             f"{shaft.mode_frequency:.3g} Hz, resolved band {shaft.resolved_frequency:.3g} Hz)"]
    for cause in diagnosis.causes:
        side = f" ({cause.side} side)" if cause.side and cause.structure == "two_mass" else ""
        lines += [f"  {cause.effect}{side}: {name} = {value_text(cause, name)}, gain {100 * cause.gain:.1f} %"
                  for name in cause.parameters]
    if diagnosis.causes:
        lines.append(f"  (gain: {GAIN_DEFINITION})")
    for label, causes in (("two-mass", diagnosis.two_mass_causes), ("rigid-body", diagnosis.rigid_body.causes)):
        lines.append(f"  {label} model names: {'; '.join(cause_summary(cause) for cause in causes) or 'none'}")
    lines.append(diagnosis.sentence)
    if diagnosis.encoder_skew is not None:
        lines.append(f"  {diagnosis.skew_sentence()}")
    for structure, models in (("two-mass", (diagnosis.baseline, diagnosis.extended)),
                              ("rigid-body", (diagnosis.rigid_body.baseline, diagnosis.rigid_body.extended))):
        lines += [f"  {_fit_line(structure, model)}"
                  for model in (models[:1] if models[1] is models[0] else models)]  # no cause: the baseline only
    lines.append(f"  (fit: {FIT_DEFINITION})")
    return lines + [f"warning: {warning}" for warning in diagnosis.warnings]


# --------------------------------------------------------------------------- the report


def _search_html(diagnosis, rule):
    """The two-mass search: a row per model tried, why each was accepted or not, the rule."""
    search = [[str(step), effects_name(c), f"{c.mean_fit_percent:.2f}", f"{100 * c.gain:.1f}",
               f"{c.t_statistic:.1f}", parameter_text(c.parameter), "yes" if c.accepted else "no"]
              for step, c in enumerate(diagnosis.candidates, start=1)]
    table = table_html(["#", "model", "k-step fit % (mean)", "gain %", "t", "added parameter (95 % CI)",
                        "accepted"], search, text_columns=(1, 5, 6))
    why = "".join(f"<li><b>{html.escape(effects_name(c))}</b>: {html.escape(c.reason)}</li>"
                  for c in diagnosis.candidates)
    return (table + f"<p>Why each model was accepted or not (numbered as in the table):</p><ol>{why}</ol>"
            + f"<p>{html.escape(rule)}</p>")


def _fits_html(diagnosis, horizon):
    """Each model tried: its validation fit per speed, k-step, ahead and free run."""
    speeds = list(diagnosis.candidates[0].fit_percent) if diagnosis.candidates else []
    kinds = (("k-step", "fit_percent"), (f"{horizon:g} s ahead", "ahead_fit_percent"),
             ("free run", "free_run_fit_percent"))
    fits = [[str(step), *(f"{getattr(c, key)[name]:.2f}" for name in speeds for _, key in kinds)]
            for step, c in enumerate(diagnosis.candidates, start=1)]
    return table_html(["#", *(f"{name}: {kind}" for name in speeds for kind, _ in kinds)], fits, text_columns=())


def _parameters_html(diagnosis):
    """The extended model's values calibrated on the whole record, each as :func:`shown_value` prints it."""
    rows = [[name, f"{p.nominal:.5g}", f"{shown_value(p):.5g}", f"{p.stderr:.3g}",
             f"{p.ci95[0]:.5g} .. {p.ci95[1]:.5g}", f"{p.lower:.4g} .. {p.upper:.4g}", p.unit]
            for name, p in diagnosis.whole_record.parameters.items()]
    return table_html(["parameter", "start (rig file)", "fitted", "std. error", "95 % CI", "bounds", "unit"], rows,
                      text_columns=(0, 6))


def _structures_html(diagnosis, horizon):
    """The shaft's resolution, which model names the causes, and both models' causes and fits side by side."""
    if diagnosis.rigid_body is None:
        return ""
    rows = []
    for label, causes, stage in (("two-mass", diagnosis.two_mass_causes, diagnosis),
                                 ("rigid body", diagnosis.rigid_body.causes, diagnosis.rigid_body)):
        named = "; ".join(cause_summary(cause) for cause in causes) or "none"
        fits = " / ".join(f"{v:.2f}" for v in stage.extended.fit_percent.values())
        ahead = " / ".join(f"{v:.2f}" for v in stage.extended.ahead_fit_percent.values())
        rows.append([label, named, fits, ahead])
    speeds = " / ".join(name.removesuffix("_speed") for name in diagnosis.extended.fit_percent) + " speed"
    table = table_html(["model", "causes (95 % CI)", f"k-step fit %, {speeds}",
                        f"{horizon:g} s ahead fit %, {speeds}"], rows, text_columns=(0, 1))
    skew = f"<p>{html.escape(diagnosis.skew_sentence())}</p>" if diagnosis.encoder_skew is not None else ""
    return f"<p>{html.escape(resolution_sentence(diagnosis.shaft, diagnosis.measurements))}</p>" + skew + table


def _summary_html(diagnosis):
    """The causes, the answer's sentence, the warnings and the prediction mode."""
    warnings = "".join(f"<li>{html.escape(w)}</li>" for w in diagnosis.warnings)
    return (f'<p class="summary"><b>Causes: {html.escape(_cause_list(diagnosis.causes))}.</b> '
            f"{html.escape(diagnosis.sentence)}</p>"
            + (f"<p><b>Warnings</b></p><ul>{warnings}</ul>" if warnings else "")
            + f"<p>Prediction mode: {html.escape(diagnosis.prediction_mode)}.</p>")


def diagnosis_report(diagnosis, overlay, residuals, *, rule, horizon, title="", rig_text=""):
    """A self-contained HTML report: verdict, warnings, overlays, residuals, search, parameters.

    Parameters
    ----------
    diagnosis : Diagnosis
    overlay : matplotlib.figure.Figure
        Measured against predicted (:meth:`~backlash_df.identify.diagnose.Diagnosis.plot`); closed here.
    residuals : dict of str to matplotlib.figure.Figure
        ``{"baseline": figure, "extended": figure}``: each model's residual analysis
        (:meth:`~backlash_df.identify.residuals.ResidualAnalysis.plot`); closed here.
    rule : str
        The significance rule the search applied (:data:`~backlash_df.identify.diagnose.RULE`).
    horizon : float
        The ahead prediction's horizon, s (:data:`~backlash_df.identify.diagnose.VALIDATION_HORIZON`).
    title : str
        Page title (default "Diagnosis of" and the record's source).
    rig_text : str
        The rig file's text, shown as it is (not shown when empty).

    Returns
    -------
    str
    """
    overlay_html = figure_html(overlay, "Validation part: measured speeds against the k-step predictions, "
                                        "before (baseline) and after (extended) the extension.")
    residual_html = [figure_html(figure, f"{label}: residual over time, against theta_d and shaft torque, spectrum, "
                                         f"autocorrelation and cross-correlation with the motor torque (99 % band "
                                         f"grey).")
                     for label, figure in residuals.items()]
    return html_page(title or f"Diagnosis of {diagnosis.measurements.source}", [
        ("", _summary_html(diagnosis)), *rig_sections(rig_text),
        ("Measured against predicted", overlay_html),
        ("Two-mass and rigid-body model", _structures_html(diagnosis, horizon)),
        ("Forward selection and backward check (two-mass model)", _search_html(diagnosis, rule)),
        ("Validation fit per speed (%) of each model searched, numbered as above", _fits_html(diagnosis, horizon)),
        ("What the model gets wrong", "\n".join(residual_html)),
        ("Calibrated parameters of the extended model on the whole record (start = rig file value; effects start "
         "at 0)", _parameters_html(diagnosis)),
    ])
