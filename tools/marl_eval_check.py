"""An evaluation's marl_eval.json through the marl-eval package's own format check
(DiagnoseData) and pipeline (data_process_pipeline, create_matrices_for_rliable,
aggregate_scores), for one environment of the file per call: marl-eval's
create_matrices_for_rliable keeps state between calls.

    python3 tools/marl_eval_check.py runs/EVAL/marl_eval.json avacraft-pve

It needs the id-marl-eval package, which does not install as published on Python 3.11 (its
sdist wants pkg_resources, numpy and Cython at build time, and pins pandas 1.4.4); what
worked here (2026-11-26):

    pip install numpy "setuptools<70" wheel
    pip install --no-deps --no-build-isolation id-marl-eval==0.0.4
    pip install "pandas<2.3" rliable seaborn matplotlib colorcet colorama tqdm
"""
import json, sys
import matplotlib
matplotlib.use("Agg")
from marl_eval.utils.diagnose_data_errors import DiagnoseData
from marl_eval.utils.data_processing_utils import create_matrices_for_rliable, data_process_pipeline
from marl_eval.plotting_tools.plotting import aggregate_scores

raw = json.load(open(sys.argv[1]))
env = sys.argv[2]
raw = {env: raw[env]}
assert all(DiagnoseData(raw_data=raw).check_data()[env].values())
norm = ["damage_dealt"]
processed = data_process_pipeline(raw_data=raw, metrics_to_normalize=norm)
matrix, _ = create_matrices_for_rliable(data_dictionary=processed, environment_name=env, metrics_to_normalize=norm)
fig, scores, _ = aggregate_scores(dictionary=matrix, metric_name="win_rate", metrics_to_normalize=norm, save_tabular_as_latex=False)
print(f"== {env}: {len(raw[env])} tasks: " + ", ".join(sorted(raw[env])))
for algo, s in scores.items():
    print(f"{algo:28s} IQM {s['IQM']:18s} mean {s['Mean']}")
fig.savefig(f"aggregate-{env}.png")
