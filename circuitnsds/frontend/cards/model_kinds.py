"""The model types of the code-model and MOSFET families, as plain data.

:mod:`~circuitnsds.frontend.cards.models` reads every ``.model`` card and needs only to know
which family a type belongs to: these tables live here so that it can, without importing
:mod:`~circuitnsds.frontend.cards.xspice`, :mod:`~circuitnsds.frontend.cards.xspice_digital`
or :mod:`~circuitnsds.frontend.cards.mosfets` (and their element classes) for a netlist
that uses none of them.
"""

MOS_KINDS = {"vdmos": "VDMOS power MOSFET", "nmos": "n-channel MOSFET", "pmos": "p-channel MOSFET"}
"""MOSFET model types (``.model NAME VDMOS|NMOS|PMOS``) -> what they are."""

SMOOTH_KINDS = {"npn": "NPN bipolar transistor", "pnp": "PNP bipolar transistor",
                "njf": "n-channel JFET", "pjf": "p-channel JFET"}
"""Model types of the smooth semiconductor devices (:mod:`~circuitnsds.frontend.cards.smooth_devices`)
-> what they are."""

POWER_KINDS = {"igbt": "IGBT", "scr": "thyristor (SCR)"}
"""Power-device model types (``.model NAME IGBT|SCR``, used by ``Z`` lines) -> what they are."""

ANALOG_BLOCKS = {
    "gain": {"in_offset": 0.0, "gain": 1.0, "out_offset": 0.0},
    "summer": {"in_offset": (), "in_gain": (), "out_gain": 1.0, "out_offset": 0.0},
    "limit": {"in_offset": 0.0, "gain": 1.0, "out_lower_limit": None, "out_upper_limit": None,
              "limit_range": 1e-6, "fraction": False},
    "int": {"in_offset": 0.0, "gain": 1.0, "out_lower_limit": None, "out_upper_limit": None,
            "limit_range": 1e-6, "out_ic": 0.0},
    "d_dt": {"gain": 1.0, "out_offset": 0.0, "out_lower_limit": None, "out_upper_limit": None,
             "limit_range": 1e-6},
    "lcouple": {"num_turns": 1.0},
    "hyst": {"in_low": 0.0, "in_high": 1.0, "hyst": 0.1, "out_lower_limit": 0.0,
             "out_upper_limit": 1.0, "input_domain": 0.01, "fraction": True},
}
"""Supported analog code models: parameter -> ngspice default (``None``: no default)."""

_GATE = {"rise_delay": 1e-9, "fall_delay": 1e-9, "input_load": 1e-12}
DIGITAL_PARTS: dict[str, dict[str, object]] = {
    "d_inverter": dict(_GATE),
    "d_and": dict(_GATE),
    "d_or": dict(_GATE),
    "d_srlatch": {"sr_delay": 1e-9, "enable_delay": 1e-9, "set_delay": 1e-9, "reset_delay": 1e-9,
                  "ic": 0.0, "rise_delay": 1e-9, "fall_delay": 1e-9, "sr_load": 1e-12,
                  "enable_load": 1e-12, "set_load": 1e-12, "reset_load": 1e-12},
    "d_dff": {"clk_delay": 1e-9, "set_delay": 1e-9, "reset_delay": 1e-9, "ic": 0.0,
              "rise_delay": 1e-9, "fall_delay": 1e-9, "data_load": 1e-12, "clk_load": 1e-12,
              "set_load": 1e-12, "reset_load": 1e-12},
    "adc_bridge": {"in_low": 0.1, "in_high": 0.9, "rise_delay": 1e-9, "fall_delay": 1e-9},
    "dac_bridge": {"out_low": 0.0, "out_high": 1.0, "out_undef": 0.5, "input_load": 1e-12,
                   "t_rise": 1e-9, "t_fall": 1e-9},
    "d_pwm": {"cntl_array": None, "dc_array": None, "frequency": 1e6, "init_phase": 0.0,
              "rise_delay": 1e-9, "fall_delay": 1e-9},
}
"""Supported digital code models: parameter -> ngspice default (ngspice 39's ifspec.ifs)."""

CODE_MODELS = {**ANALOG_BLOCKS, **DIGITAL_PARTS}
"""Every supported code model: parameter -> ngspice default."""
