"""The binding every full screen over the main one shares: Esc or q goes back."""

from textual.binding import Binding

BACK = [Binding("escape,q", "app.pop_screen", "Back", id="screen.back")]
