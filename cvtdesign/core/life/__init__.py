"""Heat, wear and life of every contact over a duty cycle (docs/life.md): the duty cycle (duty.py), the
materials' ageing constants (props.py), rolling resistance from hysteresis (hysteresis.py), the rollers'
temperatures (thermal.py), wear (wear.py), rolling-contact fatigue and Miner's rule (fatigue.py), and the
run over a variant's model with the temperature fed back (run.py)."""
