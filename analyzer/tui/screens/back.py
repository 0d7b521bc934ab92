"""The binding every full screen over the main one shares: Esc or q goes back."""

from textual.binding import Binding, BindingType

BACK: list[BindingType] = [Binding("escape,q", "app.pop_screen", "Back", id="screen.back")]
