"""The learned meta-level (paper Sec. 4.2-4.3): the optimisation MDP (`env`), the policy and its
PPO training (`policy`), and the landscape-aware selection of training problems (`lam`)."""
