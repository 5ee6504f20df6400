"""docs/img/tcs2_contact_models.png: press-to-touch against resting-probe profiles, 1# and 4#."""
import numpy as np, matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
from experiments.protocol import load_protocol
from experiments.session.setup import simulated_target_profile
from participants_schema import Participant
from experiments.display.tcs2.profile_compiler import compile_profile, segments_to_samples

p = load_protocol("roughness_recognition_tcs2")
rec = Participant(id="P01", measured_skin_m=680e-6)
fig, grid = plt.subplots(2, 2, figsize=(10, 6.4), sharey=True)
for col, (rid, um) in enumerate(((1, 1.6), (4, 100.0))):
    prof = simulated_target_profile(p, rec, "A", 680, rid, um)
    t = np.asarray(prof.times)
    press = np.asarray(prof._prof.temperature)
    rest = np.asarray(prof.temperature)
    c = compile_profile(t, rest, start_C=35.5, limits=p.display.safety_limits())
    print(rid, c.count, round(c.max_deviation_C, 3), prof.parameters["resting_catch_up_s"],
          prof.parameters["resting_max_change_C"])
    for row, xmax in enumerate((20.0, 3.0)):
        ax = grid[row, col]
        ax.plot(t, press, label="press-to-touch target (the paper's display)", color="C0")
        ax.plot(t, rest, label="resting probe: from the skin at 10 °C/s, then the target", color="C1")
        ax.plot(t, segments_to_samples(c.start_C, c.segments, t), "--", color="k", lw=0.8,
                label=f"TCS II segments ({c.count}, max deviation {c.max_deviation_C:.2f} °C)")
        ax.set_xlim(0, xmax)
        ax.set_xlabel("time from the start of stimulation, s")
        if row == 0:
            ax.set_title(f"sample {rid}# ({um:g} µm): meets the target after "
                         f"{prof.parameters['resting_catch_up_s']:.2f} s")
            ax.legend(fontsize=7, loc="upper right")
        if col == 0:
            ax.set_ylabel("temperature, °C")
fig.tight_layout()
fig.savefig("docs/img/tcs2_contact_models.png", dpi=110)
