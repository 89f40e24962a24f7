"""The rendering layer: sentences, tables and HTML rendered from the results' data.

The rooms of the flow decide with data (:mod:`backlash_df.verdict` returns an
:class:`~backlash_df.verdict.Outcome` and its :class:`~backlash_df.verdict.Evidence`,
a tuning its certificate and margin, a diagnosis its causes and fits); the words a
person reads are made here, apart from the decisions, as python-control keeps
``timeresp`` apart from ``timeplot`` and lmfit keeps its reports in ``printfuncs``.
A result's ``tables()``, ``sentences()`` and ``report_html()`` are one-line calls of
these functions, and the command line prints what they return.  The modules read
the results' attributes and import none of the result modules; a report's figures
are drawn by the results (their ``plot()``) and handed in.  Every arrow points down,
into :mod:`backlash_df.render.html`, :mod:`backlash_df.disturbances` (the
disturbances' words) and :mod:`backlash_df.config` (the rig values' units).

:mod:`backlash_df.render.html`
    the pieces of the self-contained HTML pages, and number formats.
:mod:`backlash_df.render.verdict`
    a verdict's reason as one sentence, the verdict and orbit tables.
:mod:`backlash_df.render.prediction`
    the table of predicted and simulated cycles, a prediction's report.
:mod:`backlash_df.render.analysis`
    the ``predict`` tables and lines of a loop's analysis, and its report.
:mod:`backlash_df.render.tuning`
    a tuning's answer, verdict and margin, its front, and its report.
:mod:`backlash_df.render.sweeps`
    a design map's verdict grids, their key and counts, and its report; a rig value's label.
:mod:`backlash_df.render.continuation`
    a branch's tables of orbits and DF cycles, its special points, and its report.
:mod:`backlash_df.render.diagnosis`
    a diagnosis' values and sentences, the ``diagnose`` lines, and its report.
:mod:`backlash_df.render.reproduce`
    the paper's Table I and Figure 2 as text.
"""
