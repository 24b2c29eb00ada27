"""Small CPU processors for testing the network model and the scheduler without GL."""

from vgraph import FloatProperty, Inport, IntProperty, Outport, Processor, StringProperty


class Number(Processor):
    """Outputs its value."""
    category = "Test"
    outports = [Outport("value", float)]
    value = FloatProperty(1.0, min=-100.0, max=100.0)
    mode = StringProperty("plain")

    def initialize(self):
        self.initialize_count = getattr(self, "initialize_count", 0) + 1

    def process(self):
        self.process_count = getattr(self, "process_count", 0) + 1
        return self.value


class Sum(Processor):
    """Adds its inputs."""
    category = "Test"
    inports = [Inport("values", float, multiple=True), Inport("offset", float, optional=True)]
    outports = [Outport("value", float)]

    def process(self, values, offset):
        return sum(values) + (offset or 0.0)


class Fragile(Processor):
    """Fails while `fail` is nonzero."""
    category = "Test"
    inports = [Inport("value", float)]
    outports = [Outport("value", float)]
    fail = IntProperty(0, min=0, max=1)

    def process(self, value):
        if self.fail:
            raise ZeroDivisionError("deliberate failure")
        return value


class Collect(Processor):
    """A sink."""
    category = "Test"
    inports = [Inport("value", float)]

    def process(self, value):
        pass


class Text(Processor):
    """Outputs a string: a data type that does not fit float inports."""
    category = "Test"
    outports = [Outport("text", str)]

    def process(self):
        return "hello"


class Powers(Processor):
    """Its input and, only when something reads it, the input squared (an on-demand outport)."""
    category = "Test"
    inports = [Inport("value", float)]
    outports = [Outport("value", float), Outport("square", float, on_demand=True)]

    def process(self, value):
        self.squared = self.wants("square")
        return {"value": value, "square": value * value if self.squared else None}


ALL = [Number, Sum, Fragile, Collect, Text, Powers]
