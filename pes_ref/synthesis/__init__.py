"""Synthesis: optimizers (:mod:`.optimizers`), the funnel and oscillator design problems,
plans and training loop (:mod:`.designs`), and design files (:mod:`.design_file`)."""
