"""Jupyter widgets (ipywidgets 8): a form that publishes a message as its sliders move (``%pub --widget``),
one that sets parameters as they move (``%params --widget``), and a bag player's controls (``%bag widget NODE``).

The form's controls come from the message type (:func:`ipyros.core.msgform.form_fields`):
a slider a number, a toggle a bool, a text box a string. Moving one publishes the message at
once; a rate above 0 and the play button publish it again and again until the button is
pressed again (or the form closed). In a terminal there is no widget: the magic says so.
"""

from __future__ import annotations

import threading
from typing import Any, Callable, Optional

from IPython.core.error import UsageError

from ..core import msgtypes
from ..core.msgform import FormField, form_fields, message_from, param_field

__all__ = ["BagPlayerForm", "Form", "ParamsForm", "PublisherForm", "widgets_module"]


def widgets_module() -> Any:
    """ipywidgets, or a one-line error saying how to get it."""
    try:
        import ipywidgets
    except ImportError:
        raise UsageError("widgets need ipywidgets: pip install 'ipyros[jupyter]' (bash run.sh notebook installs "
                         "it)") from None
    return ipywidgets


class Form:
    """What each form here is: one box of controls (``widget``), shown as the cell's result, closed as a whole."""

    widget: Any

    def close(self) -> None:
        """Close the form's widgets (a closed form changes nothing any more)."""
        self.widget.close()

    def _ipython_display_(self) -> None:
        from IPython.display import display

        display(self.widget)


def _left_out(widgets: Any, paths: list[str]) -> list[Any]:
    """A line naming what the form has no control for (none: no line)."""
    return [widgets.Label(value=f"not in the form: {', '.join(paths)}")] if paths else []


class PublisherForm(Form):
    """A form for messages of ``cls`` on ``topic``: ``send(msg)`` publishes one; ``fields`` maps each dotted path to
    its control (``form.fields["linear.x"].value = 0.3`` publishes, as moving the slider does). ``guarded_by``
    (a guard's limits, and whose it is) spans those sliders within the limits: what they show is what passes."""

    def __init__(self, topic: str, cls: type, send: Callable[[Any], None], initial: Any = None,
                 guarded_by: Optional[tuple[str, dict[str, Any]]] = None) -> None:
        widgets = widgets_module()
        self.topic, self._cls, self._send = topic, cls, send
        owner, limits = guarded_by or ("", {})
        specs, left_out = form_fields(cls, initial, {path: (low, high) for path, (low, high) in limits.items()})
        self.fields: dict[str, Any] = {spec.path: _control(widgets, spec) for spec in specs}
        self.sent = 0
        self.problem = ""  # the last message that could not be sent, and why
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._stop.set()  # not publishing at a rate
        self.rate = widgets.BoundedFloatText(value=0.0, min=0.0, max=1000.0, step=1.0, description="rate (Hz)")
        self.play = widgets.ToggleButton(value=False, description="publish at rate", icon="play")
        self.status = widgets.Label(value=f"{topic}: nothing sent yet")
        for control in self.fields.values():
            control.observe(lambda change: self._changed(), names="value")
        self.play.observe(lambda change: self._playing(change["new"]), names="value")
        through = f": through the guard of {owner}, sliders within its limits" if guarded_by else ""
        self.widget = widgets.VBox([widgets.HTML(value=f"<b>{topic}</b> ({msgtypes.type_name(cls)}){through}"),
                                    *self.fields.values(), widgets.HBox([self.rate, self.play]), self.status,
                                    *_left_out(widgets, left_out)])

    # -- what it sends ---------------------------------------------------------------------------
    def message(self) -> Any:
        """The message the controls say now."""
        return message_from(self._cls, {path: control.value for path, control in self.fields.items()})

    def publish(self) -> None:
        """Send the message the controls say, once (what a change does)."""
        try:
            msg = self.message()
            self._send(msg)
        except Exception as error:  # noqa: BLE001 - said on the form, in one line: a form must not raise at a slider
            self.problem = str(error).splitlines()[0]
            self.status.value = f"{self.topic}: not sent: {self.problem}"
            return
        with self._lock:
            self.sent += 1
            self.status.value = f"{self.topic}: {self.sent} sent"

    def _changed(self) -> None:
        if self._stop.is_set():  # at a rate, the next tick sends the new values
            self.publish()

    def _playing(self, on: bool) -> None:
        if not on:
            self._stop.set()
            return
        if not self.rate.value > 0:
            self.status.value = f"{self.topic}: give a rate above 0 Hz to publish again and again"
            self.play.value = False
            return
        self._stop.clear()
        threading.Thread(target=self._repeat, name="ipyros-widget-pub", daemon=True).start()

    def _repeat(self) -> None:
        while not self._stop.is_set():
            self.publish()
            self._stop.wait(1.0 / max(self.rate.value, 1e-3))

    def close(self) -> None:
        """Stop publishing and close the form's widgets."""
        self._stop.set()
        super().close()

    def __repr__(self) -> str:
        return f"<PublisherForm of {self.topic}: {len(self.fields)} controls, {self.sent} sent>"


class ParamsForm(Form):
    """The parameters ``values`` ({global name: value}) as controls within the ranges their nodes give (``describe``),
    each set with ``write(name, value)`` as it moves (``form.fields[name].value = 3`` sets it, as the slider does)."""

    def __init__(self, values: dict[str, Any], describe: Callable[[str], dict[str, Any]],
                 write: Callable[[str, Any], Any]) -> None:
        widgets = widgets_module()
        self._write = write
        self.fields: dict[str, Any] = {}
        left_out = []
        for name, value in sorted(values.items()):
            try:
                described = describe(name)
            except Exception:  # noqa: BLE001 - a node that does not say: a range around the value
                described = {}
            spec = param_field(name, value, described)
            if spec is None:
                left_out.append(name)
                continue
            control = self.fields[name] = _control(widgets, spec)
            control.observe(lambda change, name=name: self._set(name, change["new"]), names="value")
        self.status = widgets.Label(value=f"{len(self.fields)} parameter{'s' * (len(self.fields) != 1)}: move one "
                                          "to set it")
        self.widget = widgets.VBox([*self.fields.values(), self.status, *_left_out(widgets, left_out)])

    def _set(self, name: str, value: Any) -> None:
        try:
            kept = self._write(name, value)
        except Exception as error:  # noqa: BLE001 - said on the form, in one line
            self.status.value = f"{name}: not set: {str(error).splitlines()[0]}"
            return
        self.status.value = f"{name} = {kept!r}"

    def __repr__(self) -> str:
        return f"<ParamsForm: {len(self.fields)} parameters>"


class BagPlayerForm(Form):
    """The controls of the bag a node plays (``baseBag``): pause/resume, step, a seek slider over the bag's length,
    the rate and looping, each a control the player answers (``control(text)``: a
    :class:`~ipyros.tools.bagplay.PlayerState`); the state the last answer gave, below them."""

    def __init__(self, control: Callable[[str], Any]) -> None:
        widgets = widgets_module()
        self._control = control
        state = control("state")
        self.paused = widgets.ToggleButton(value=state.paused, description="paused", icon="pause")
        self.step = widgets.Button(description="step", icon="step-forward")
        self.seek = widgets.FloatSlider(value=state.at, min=0.0, max=max(state.length, 1e-3), step=0.01,
                                        description="seek (s)", continuous_update=False, readout_format=".2f")
        self.rate = widgets.FloatLogSlider(value=state.rate, base=10, min=-2, max=2, step=0.05, description="rate")
        self.loop = widgets.Checkbox(value=state.loop, description="loop")
        self.status = widgets.Label(value=str(state))
        self.paused.observe(lambda change: self._do("pause" if change["new"] else "resume"), names="value")
        self.step.on_click(lambda button: self._do("step 1"))
        self.seek.observe(lambda change: self._do(f"seek {change['new']:.3f}"), names="value")
        self.rate.observe(lambda change: self._do(f"rate {change['new']:.4g}"), names="value")
        self.loop.observe(lambda change: self._do(f"loop {'on' if change['new'] else 'off'}"), names="value")
        self.widget = widgets.VBox([widgets.HBox([self.paused, self.step, self.loop]), self.seek, self.rate,
                                    self.status])

    def _do(self, text: str) -> None:
        try:
            self.status.value = str(self._control(text))
        except Exception as error:  # noqa: BLE001 - said on the form, in one line (the bag ended, a control refused)
            self.status.value = f"{text}: {str(error).splitlines()[0]}"


def _control(widgets: Any, spec: FormField) -> Any:
    if spec.kind == "float":
        return widgets.FloatSlider(value=spec.value, min=spec.low, max=spec.high, step=spec.step, description=spec.path,
                                   continuous_update=True, readout_format=".3f")
    if spec.kind == "int":
        return widgets.IntSlider(value=spec.value, min=int(spec.low), max=int(spec.high), step=1, description=spec.path)
    if spec.kind == "bool":
        return widgets.ToggleButton(value=spec.value, description=spec.path)
    return widgets.Text(value=spec.value, description=spec.path, continuous_update=False)
