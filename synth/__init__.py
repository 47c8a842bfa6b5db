"""mocap_synth: ground-truth experiments (perturbed model, motion, noise) built on mocap_mj."""
