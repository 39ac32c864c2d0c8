"""The search stages a plan is made of: constructive plans (`construct`), the start modes
(`init_modes`), the DE (`de`), the DE's memetic refinement (`refine`), the hover-time LP
(`polish`), the hover-point descent (`descent`), structural moves and kicks (`structure`) and the
final stage on the incumbent (`final`). `planner_core.pipeline` declares the order and the
budget; no stage here runs another stage's budget."""
