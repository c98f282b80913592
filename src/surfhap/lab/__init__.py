"""Lab tools: display calibration from tribometer recordings, study designs, staircases,
loss-free trial logs, and the paper-style analysis of perception studies (``sh.lab``; names
loaded on first use)."""

from surfhap._lazy import lazy_names

_MODULES = {
    "surfhap.lab.calibration": ("calibrate_display",),
    "surfhap.lab.staircase": ("Staircase", "StaircaseParams", "StaircaseResult", "run_simulated"),
    "surfhap.lab.designs": ("build_study", "study_template"),
    "surfhap.lab.analyze_study": ("analyze_study",),
    "surfhap.lab.art": ("art_anova",),
    "surfhap.lab.compare": ("compare_materials",),
    "surfhap.lab.comfort": ("default_comfort_params",),
    "surfhap.lab.psychometric": ("PsychometricFit", "fit_psychometric", "psychometric"),
    "surfhap.lab.questplus": ("QuestPlus",),
    "surfhap.lab.quest": ("Quest", "QuestParams"),
}
__all__ = sorted(name for names in _MODULES.values() for name in names)
__getattr__, __dir__ = lazy_names(__name__, _MODULES, globals())
