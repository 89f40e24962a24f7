"""The rendering layer: sentences and tables rendered from the results' data.

The rooms of the flow decide with data (:mod:`backlash_df.verdict` returns an
:class:`~backlash_df.verdict.Outcome` and its :class:`~backlash_df.verdict.Evidence`);
the words a person reads are made here, apart from the decisions, as python-control
keeps ``timeresp`` apart from ``timeplot`` and lmfit keeps its reports in
``printfuncs``.  The modules read the results' attributes and import none of the
result modules: every arrow points down, into :mod:`backlash_df.report` (HTML and
number formats) and :mod:`backlash_df.disturbances` (the disturbances' words).

:mod:`backlash_df.render.verdict`
    a verdict's reason as one sentence, the verdict and orbit tables.
"""
