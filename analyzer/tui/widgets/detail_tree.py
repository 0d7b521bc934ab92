"""The detail tree: every field of the selected event with value, unit and byte
range, its problems, and its pairing; Enter on a pairing line asks to jump
there (``Jump``), and the highlighted field's bytes are announced
(``FieldBytes``) for the hex pane."""

from __future__ import annotations

from typing import Any

from rich.text import Text
from textual.message import Message
from textual.widgets import Tree
from textual.widgets.tree import TreeNode

from ..detail import DetailNode


class DetailTree(Tree[DetailNode]):
    """Every field of the selected event, its problems, and its pairing; Enter on
    a pairing line jumps to that event."""

    class Jump(Message):
        def __init__(self, number: int) -> None:
            super().__init__()
            self.number = number

    class FieldBytes(Message):
        def __init__(self, span: tuple[int, int] | None) -> None:
            super().__init__()
            self.span = span

    def __init__(self, **kw: Any) -> None:
        super().__init__("no event selected", **kw)
        self.show_root = False
        self.guide_depth = 2

    def show(self, nodes: list[DetailNode], title: str) -> None:
        self.clear()
        self.root.set_label(title)

        def add(parent: TreeNode[DetailNode], node: DetailNode) -> None:
            label = Text(node.label, style="underline cyan" if node.jump is not None else "")
            if node.children:
                child = parent.add(label, data=node, expand=node.expanded)
                for c in node.children:
                    add(child, c)
            else:
                parent.add_leaf(label, data=node)

        for n in nodes:
            add(self.root, n)
        self.root.expand()

    def on_tree_node_selected(self, event: Tree.NodeSelected[DetailNode]) -> None:
        node = event.node.data
        if isinstance(node, DetailNode) and node.jump is not None:
            self.post_message(self.Jump(node.jump))

    def on_tree_node_highlighted(self, event: Tree.NodeHighlighted[DetailNode]) -> None:
        node = event.node.data
        if isinstance(node, DetailNode):
            self.post_message(self.FieldBytes(node.span))
