"""The identification in memory:
:func:`~mocap_mj.pipeline.api.identify` (what ``mocap-mj identify`` runs),
its :class:`~mocap_mj.pipeline.recipe.Recipe`, the :class:`~mocap_mj.pipeline.fit.Fit`
it returns, and the motion of a trial with a given model.
"""
