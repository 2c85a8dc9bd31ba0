//! Two-flux Kubelka–Munk theory (seed 000 §2). Being written.
